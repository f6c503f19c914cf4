"""The decision room: one self-contained, offline HTML page to narrow a front down and hand
over a design (docs/model.md §19).

The page holds the designs of :func:`hisopt.studies.decision_room.decision_room_data` and
draws, filters and navigates them in the browser (``decision_room.js``, no library and no
network): parallel coordinates whose brushes filter the scatter matrix, the table and the
count; a design's values, parts, damper valves' equivalent resistances (those outside the
linearisation's validated range marked), buildability verdict, verdict in the time domain (a
front design ``hisopt verify`` verified), spectra and step response against the baseline's;
filters for the front, feasibility, buildability, a load case, a layout and the variables'
bounds; reference-point and E-NAUTILUS navigation (the rules of :mod:`hisopt.optim.navigation`); CSV and problem-file
export. Numbers travel as base64 arrays: the variables and objectives as float64 (an export
is the design itself, bit for bit), the other quantities as float32, the curves as bytes on a
log scale (a picture, not a value: the design sheet has the exact ones).
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.buildability import RULES
from hisopt.errors import ConfigError, RunError
from hisopt.evaluation.valve_states import OUTSIDE_VALIDATED_RANGE, VALIDATED_RESISTANCE
from hisopt.plausibility import BOUND_TOLERANCE
from hisopt.report.tables import REPORT_CSS
from hisopt.studies.buildability import BINDING_RULE, BUILDABLE
from hisopt.studies.decision_room import KINDS, VERIFIED
from hisopt.studies.verified import VERDICTS, VERIFY_PREFIX
from hisopt.studies.verify_designs import VERIFY_HTML
from hisopt.units import display_for, is_psd

if TYPE_CHECKING:
    from hisopt.optim.results import OptimizationResult
    from hisopt.studies.decision_room import Curves, Room
    from hisopt.studies.layout_study import LayoutStudyResult

DECISION_FILE = "decision.html"
"""The page ``hisopt report`` writes next to ``report.html``."""
EXACT_GROUPS = ("variable", "objective")
"""Column groups sent as float64: an exported design and its objectives are the stored ones."""
SPECTRUM_DECADES = 8.0
"""[decades] Range of a spectrum's byte scale below its largest value (smaller values clip)."""
MISSING = 255
"""Byte of a curve sample that has no value (an unstable design)."""


def _b64(values: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(values).tobytes()).decode("ascii")


def _display(unit: str, values: np.ndarray) -> dict[str, Any]:
    shown = display_for(unit, values)
    return {"unit": shown.unit, "scale": shown.scale, "scientific": shown.scientific}


def _log_bytes(values: np.ndarray, top: float) -> tuple[np.ndarray, float]:
    """Bytes 0..254 of ``log10(values)`` over ``[top - SPECTRUM_DECADES, top]`` decades (255:
    missing) and the lowest decade."""
    low = top - SPECTRUM_DECADES
    with np.errstate(all="ignore"):
        level = np.round((np.log10(values) - low) / SPECTRUM_DECADES * 254.0)
    out = np.where(np.isfinite(level), np.clip(level, 0, 254), MISSING)
    return out.astype(np.uint8), low


def curve_payload(curves: Curves, baseline: dict[str, Curves]) -> dict[str, Any]:
    """The curves of every row as bytes (``n x (F x outputs + P)``) and how to read them."""
    n = len(curves.spectra)
    parts, scales = [], []
    for j, name in enumerate(curves.outputs):
        finite = curves.spectra[..., j][np.isfinite(curves.spectra[..., j]) & (curves.spectra[..., j] > 0)]
        top = float(np.ceil(np.log10(finite.max()))) if finite.size else 0.0
        coded, low = _log_bytes(curves.spectra[..., j], top)
        parts.append(coded)
        scales.append({"name": name, "unit": curves.units[name], "low": low, "decades": SPECTRUM_DECADES, "display": _display(curves.units[name], finite[:1])})
    step = curves.step
    finite = step[np.isfinite(step)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    hi = hi if hi > lo else lo + 1.0
    with np.errstate(all="ignore"):
        level = np.round((step - lo) / (hi - lo) * 254.0)
    parts.append(np.where(np.isfinite(level), np.clip(level, 0, 254), MISSING).astype(np.uint8))
    rows = np.concatenate([p.reshape(n, -1) for p in parts], axis=1)
    return {
        "f_hz": curves.f_hz.tolist(),
        "t_s": curves.t_s.tolist(),
        "spectra": scales,
        "step": {"low": lo, "high": hi, "unit": "rad", "display": _display("rad", np.array([hi])), "step_g": curves.step_g},
        "bytes": _b64(rows),
        "width": int(rows.shape[1]),
        "baseline": {name: _baseline_curves(c) for name, c in baseline.items()},
    }


def _baseline_curves(curves: Curves) -> dict[str, list]:
    """The baseline design's curves as numbers (NaN as -1: off every log axis; 0 rad)."""
    return {"spectra": np.nan_to_num(curves.spectra[0].T, nan=-1.0).tolist(), "step": np.nan_to_num(curves.step[0], nan=0.0).tolist()}


def room_payload(room: Room, sheets: dict[int, str] | None = None, verify_pages: dict[int, str] | None = None) -> dict[str, Any]:
    """Everything the page reads, as JSON-ready data (arrays as base64); ``sheets`` and
    ``verify_pages`` the relative links of the front rows' design sheets and ``verify.html``."""
    table = room.table
    columns = []
    for name, group in room.groups.items():
        values = table[name].to_numpy(dtype=float)
        exact = group in EXACT_GROUPS
        unit = room.units[name]
        columns.append(
            {
                "name": name,
                "group": group,
                "unit": unit,
                "display": _display(unit, values),
                "log": bool(is_psd(unit) or (group == "objective" and np.nanmin(values) > 0)),
                "type": "f64" if exact else "f32",
                "data": _b64(values.astype(np.float64 if exact else np.float32)),
            }
        )
    repeated = len({s.name for s in room.sources}) < len(room.sources)  # a layout's seeds
    sources = [
        {
            "name": s.name,
            "label": f"{s.name} ({Path(s.location).name})" if repeated else s.name,
            "location": s.location,
            "variables": list(s.problem.variable_names),
            "bounds": room.bounds[s.name],
            "template": room.templates[s.name],
        }
        for s in room.sources
    ]
    kind_names = list(KINDS)
    rules = ["", *RULES]  # "": a design without a verdict
    verdicts = ["", *VERDICTS]  # "": a design not verified in the time domain
    return {
        "rows": len(table),
        "objectives": room.objectives,
        "columns": columns,
        "sources": sources,
        "kinds": kind_names,
        "source": _b64(table["source_index"].to_numpy(dtype=np.uint8)),
        "kind": _b64(table["kind"].map(kind_names.index).to_numpy(dtype=np.uint8)),
        "row": _b64(table["row"].to_numpy(dtype=np.int32)),
        "feasible": _b64(table["feasible"].to_numpy(dtype=np.uint8)),
        "front": _b64(table["front"].to_numpy(dtype=np.uint8)),
        "buildable": _b64(table[BUILDABLE].to_numpy(dtype=np.uint8)),
        "rules": rules,
        "binding_rule": _b64(table[BINDING_RULE].map(rules.index).to_numpy(dtype=np.uint8)),
        "verdicts": verdicts,
        "verified": _b64(table[VERIFIED].map(verdicts.index).to_numpy(dtype=np.uint8)),
        "bound_tolerance": BOUND_TOLERANCE,
        "validated_resistance": VALIDATED_RESISTANCE,
        "outside_range": OUTSIDE_VALIDATED_RANGE,
        "curves": curve_payload(room.curves, room.baseline),
        "sheets": {str(k): v for k, v in (sheets or {}).items()},
        "verify_pages": {str(k): v for k, v in (verify_pages or {}).items()},
    }


def _asset(name: str) -> str:
    return resources.files("hisopt.report").joinpath(name).read_text(encoding="utf-8")


def decision_room_page(room: Room, title: str, note: str = "", sheets: dict[int, str] | None = None, verify_pages: dict[int, str] | None = None) -> str:
    """The page (HTML text) of ``room``; ``note`` a line on where the designs come from,
    ``sheets`` and ``verify_pages`` the design sheets and verifications already written
    (front row: relative link)."""
    data = json.dumps(room_payload(room, sheets, verify_pages), separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data: blob:">
<style>{REPORT_CSS}{_asset("decision_room.css")}</style></head>
<body><h1>{html.escape(title)}</h1>
<p class="meta">{html.escape(note)}</p>
{_asset("decision_room.html")}
<script type="application/json" id="room-data">{data}</script>
<script>{_asset("decision_room.js")}</script>
</body></html>
"""


def write_decision_room(
    room: Room, path: str | Path, title: str, note: str = "", sheets: dict[int, str] | None = None, verify_pages: dict[int, str] | None = None
) -> Path:
    """Write the page of ``room`` to ``path`` (atomically); the path."""
    from hisopt.io import atomic_write_text

    path = Path(path)
    atomic_write_text(path, decision_room_page(room, title, note, sheets, verify_pages))
    return path


def run_decision_room(run_dir: str | Path) -> Path:
    """Write ``RUN_DIR/decision.html``, the decision room of a run (its front, refined front
    and other evaluations, :func:`hisopt.studies.decision_room.run_sources`); its path."""
    from hisopt.studies.decision_room import decision_room_data, run_sources

    run_dir = Path(run_dir)
    sources = run_sources(run_dir)
    room = decision_room_data(sources)
    sheets = {int(p.parent.name.removeprefix("sheet-")): f"{p.parent.name}/{p.name}" for p in run_dir.glob("sheet-*/sheet.html") if p.parent.name[6:].isdigit()}
    front_rows = room.table.loc[room.table[VERIFIED].ne("").to_numpy(dtype=bool), "row"]
    pages = {int(r): f"{VERIFY_PREFIX}{int(r)}/{VERIFY_HTML}" for r in front_rows if (run_dir / f"{VERIFY_PREFIX}{int(r)}" / VERIFY_HTML).is_file()}
    counts = room.table["kind"].value_counts()
    parts = [f"{int(counts.get('front', 0))} front designs"]
    if counts.get("refined"):
        parts.append(f"{int(counts['refined'])} refined")
    if counts.get("evaluated"):
        parts.append(f"{int(counts['evaluated'])} other evaluated designs (the latest)")
    if len(front_rows):
        parts.append(f"{len(front_rows)} front designs verified in the time domain (hisopt verify)")
    note = f"{run_dir}: {', '.join(parts)} of {sources[0].problem.name}; every quantity in engineering units, exports in SI."
    return write_decision_room(room, run_dir / DECISION_FILE, f"Decision room: {sources[0].problem.name}", note, sheets, pages)


def study_decision_room(result: LayoutStudyResult) -> Path | None:
    """Write ``DIR/decision.html``, the decision room over a layout study's fronts (every
    layout and seed, :func:`hisopt.studies.decision_room.layout_sources`); its path, None when
    the study has no front."""
    from hisopt.studies.decision_room import decision_room_data, layout_sources

    sources = layout_sources(result)
    if not sources or result.out is None:
        return None
    room = decision_room_data(sources)
    layouts = list(dict.fromkeys(s.name for s in sources))
    seeds = len(sources) // max(len(layouts), 1)
    note = (
        f"{result.out}: {len(room.table)} designs of the fronts of {len(layouts)} layouts ({', '.join(layouts)}) over their seeds "
        f"(about {seeds} each); filter by layout to compare; every quantity in engineering units, exports in SI."
    )
    return write_decision_room(room, result.out / DECISION_FILE, "Decision room: layout study", note)


@dataclass(frozen=True)
class DecisionRoom:
    """The decision room of a run or a layout study, for a notebook: shown in the cell
    (its page in a frame), saved as a file, its designs as a table.

    Attributes
    ----------
    room : Room
        the designs, quantities, curves and templates (:class:`hisopt.studies.decision_room.Room`)
    html : str
        the page, self-contained
    """

    room: Room
    html: str

    @property
    def table(self) -> pd.DataFrame:
        """[SI] One row per design: source, kind, row, every quantity, feasible, front."""
        return self.room.table

    @property
    def front(self) -> pd.DataFrame:
        """[SI] The designs on the front (what the page navigates over without filters)."""
        return self.room.table[self.room.table["front"].to_numpy(dtype=bool)]

    def asf(self, reference: Sequence[float]) -> pd.Series:
        """[SI] The front design closest to the aspiration ``reference`` (one value per
        objective, SI), as the page's reference point picks it
        (:func:`hisopt.optim.decision.asf_index`)."""
        from hisopt.optim.decision import asf_index

        front = self.front
        return front.iloc[asf_index(front[self.room.objectives].to_numpy(dtype=float), np.asarray(reference, dtype=float))]

    def enautilus(self, picks: Sequence[int], steps: int = 5, k: int = 4) -> list[pd.DataFrame]:
        """The E-NAUTILUS steps of the page over the front (:mod:`hisopt.optim.navigation`)
        taking option ``picks[i]`` at step ``i``: per step a table of its options, each with its
        intermediate point and the best value still reachable per objective [SI], the designs
        reachable and the representative design's row of :attr:`table`."""
        from hisopt.optim.decision import log_scale, normalised_log
        from hisopt.optim.navigation import enautilus_walk

        front = self.front
        f = front[self.room.objectives].to_numpy(dtype=float)
        ideal, span = log_scale(f)
        out = []
        for options in enautilus_walk(normalised_log(f)[0], list(picks), steps, k):
            rows = {}
            for name_j, (name, lo, sp) in enumerate(zip(self.room.objectives, ideal, span, strict=True)):
                rows[name] = [10 ** (lo + o.point[name_j] * sp) for o in options]
                rows[f"{name} best"] = [10 ** (lo + o.best[name_j] * sp) for o in options]
            rows["reachable"] = [len(o.reachable) for o in options]
            rows["design"] = [int(front.index[o.representative]) for o in options]
            out.append(pd.DataFrame(rows))
        return out

    def save(self, path: str | Path) -> Path:
        """Write the page to ``path``; its path."""
        from hisopt.io import atomic_write_text

        atomic_write_text(Path(path), self.html)
        return Path(path)

    def _repr_html_(self) -> str:
        # A frame of its own: the page's script and styles stay out of the notebook's.
        return f'<iframe srcdoc="{html.escape(self.html, quote=True)}" style="width:100%;height:2300px;border:1px solid #e3e6ea"></iframe>'


def decision_room(source: str | Path | OptimizationResult | LayoutStudyResult, max_rows: int | None = None) -> DecisionRoom:
    """The decision room of a finished run (its directory, ``hisopt optimize --out``, or the
    :class:`hisopt.OptimizationResult` of a run with one) or of a layout study's result
    (:func:`hisopt.compare_layouts`), as ``hisopt report`` writes it to ``decision.html``.

    Parameters
    ----------
    source : str | Path | OptimizationResult | LayoutStudyResult
        a finished run's directory or result, or a layout study
    max_rows : int | None, optional
        [-] designs the page holds at most (default
        :data:`hisopt.studies.decision_room.MAX_ROWS`)

    Raises
    ------
    RunError
        ``source`` is not a finished run (no or an unreadable ``run.json``, a run still
        running, interrupted or failed, a folder of another kind), or a result without a
        directory to read its designs from.
    ConfigError
        ``source`` is none of the above, or ``max_rows`` is not a whole number >= 1.
    """
    from hisopt.arguments import integer
    from hisopt.optim.results import OptimizationResult
    from hisopt.optim.runstate import finished_run
    from hisopt.studies import decision_room as data
    from hisopt.studies.layout_study import LayoutStudyResult

    limit = data.MAX_ROWS if max_rows is None else integer(max_rows, "max_rows", minimum=1, what="designs")
    if isinstance(source, OptimizationResult):
        if source.run_dir is None:
            raise RunError(
                "decision_room takes a finished run directory or layout study; this OptimizationResult has no run directory: pass out= to hisopt.optimize"
            )
        source = source.run_dir
    if isinstance(source, (str, Path)):
        finished_run(source, "decision_room")
        sources = data.run_sources(source, limit)
        title = f"Decision room: {sources[0].problem.name}"
    elif isinstance(source, LayoutStudyResult):
        sources = data.layout_sources(source, limit)
        title = "Decision room: layout study"
    else:
        raise ConfigError(f"expected a finished run's directory, its OptimizationResult or a LayoutStudyResult, got {type(source).__name__}", key="source")
    if not sources:
        raise RunError("decision_room: the layout study has no front yet; run it to the end with hisopt.compare_layouts")
    room = data.decision_room_data(sources)
    return DecisionRoom(room, decision_room_page(room, title, f"{len(room.table)} designs; every quantity in engineering units, exports in SI."))
