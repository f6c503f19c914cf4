"""The uncertainty studies as files (docs/model.md §18): ``hisopt sensitivity`` writes
``sensitivity.csv`` and ``sensitivity.html``, ``hisopt tolerance`` writes ``tolerance.csv``,
``violations.csv``, ``samples.parquet`` and ``tolerance.html``. Tables in engineering units,
CSVs in SI: the indices with a units row, the Monte Carlo tables with each row's unit in a
``unit`` column (one quantity per row)."""

from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from hisopt.io import atomic_write_text, write_csv
from hisopt.plotting.uncertainty import sensitivity_figure, tolerance_figure
from hisopt.report.embed import PageFigures
from hisopt.report.tables import REPORT_CSS, html_table
from hisopt.units import format_quantity

if TYPE_CHECKING:
    from hisopt.studies.uncertainty import SensitivityResult, ToleranceResult

SENSITIVITY_FILES = ("sensitivity.csv", "sensitivity.html")
TOLERANCE_FILES = ("tolerance.csv", "violations.csv", "samples.parquet", "tolerance.html")


def _page(title: str, meta: str, body: str, figures: PageFigures) -> str:
    """One offline page; its figures (drawn in ``body`` by :func:`_figure`) light: plotly.js
    once, compressed, their arrays as float32 (:mod:`hisopt.report.embed`)."""
    return (
        f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title><style>{REPORT_CSS}</style>{figures.head_html()}</head>'
        f'<body><h1>{html.escape(title)}</h1><p class="meta">{meta}</p>{body}{figures.scripts_html()}</body></html>'
    )


def _figure(fig, figures: PageFigures, div_id: str) -> str:
    return '<div class="figure">' + figures.div(fig, div_id) + "</div>"


def sensitivity_shown(indices: pd.DataFrame) -> pd.DataFrame:
    """The indices for reading: one row per (quantity, input), 3 decimals, ``±`` half-widths."""
    return pd.DataFrame(
        {
            "quantity": indices["quantity"],
            "input": indices["input"],
            "distribution": indices["distribution"],
            "S1 [-]": [f"{s:.3f} ± {c:.3f}" for s, c in zip(indices["S1"], indices["S1_conf"], strict=True)],
            "ST [-]": [f"{s:.3f} ± {c:.3f}" for s, c in zip(indices["ST"], indices["ST_conf"], strict=True)],
        }
    )


def total_indices_shown(indices: pd.DataFrame) -> pd.DataFrame:
    """Total indices at a glance: one row per input, one column per quantity, ``ST ± half-width``."""
    cells = indices.assign(cell=[f"{s:.2f} ± {c:.2f}" for s, c in zip(indices["ST"], indices["ST_conf"], strict=True)])
    table = cells.pivot(index="input", columns="quantity", values="cell")
    order = list(dict.fromkeys(indices["input"]))
    return table.loc[order, list(dict.fromkeys(indices["quantity"]))].reset_index()


UNCONVERGED_SHOWN = 12  # intervals listed by name when a cap stopped the doubling (all are in the CSV)


def _widest(result: SensitivityResult) -> str:
    """The widest interval, ``0.410 (ST of lam on max_tire_load_psd)``."""
    ix = result.indices
    parts = [pd.DataFrame({"index": i, "input": ix["input"], "quantity": ix["quantity"], "w": ix[f"{i}_conf"]}) for i in ("S1", "ST")]
    table = pd.concat(parts, ignore_index=True).dropna(subset=["w"])
    if table.empty:
        return "none (no quantity varies)"
    w = table.loc[table["w"].idxmax()]
    return f"{w['w']:.3f} ({w['index']} of {w['input']} on {w['quantity']})"


def sensitivity_notes(result: SensitivityResult) -> list[str]:
    """What the indices rest on, one line each: the samples, evaluations and time and whether
    every interval converged (else which did not: index, input, quantity, half-width), and
    which quantities were taken as ``log10`` and why."""
    runs = f"{result.n_base:,} base samples, {result.evaluations:,} model evaluations, {result.seconds:.1f} s"
    if result.stop == "fixed":
        lines = [f"{runs} (a fixed count, --samples); widest 95 % half-width {_widest(result)}"]
    elif result.stop == "converged":
        lines = [f"{runs}: converged, every S1 and ST 95 % half-width <= {result.target:g} (widest {_widest(result)})"]
    else:
        cap = (
            f"the next doubling ({2 * result.evaluations:,} evaluations) would pass the evaluation cap (--max-evaluations)"
            if result.stop == "evaluations"
            else f"the next doubling would take about another {result.seconds:.0f} s, past the time cap (--max-time)"
        )
        wide = result.unconverged
        lines = [f"{runs}: NOT converged, {cap}; {len(wide)} of the 95 % half-widths are above {result.target:g}:"]
        lines += [f"  {r.index} of {r.input} on {r.quantity}: ± {r.half_width:.3f}" for r in wide.head(UNCONVERGED_SHOWN).itertuples()]
        if len(wide) > UNCONVERGED_SHOWN:
            lines.append(f"  and {len(wide) - UNCONVERGED_SHOWN} more (the S1_conf and ST_conf columns of sensitivity.csv)")
    if result.logged:
        from hisopt.studies.uncertainty import quantity_unit

        spans = ", ".join(f"{q} ({format_quantity(lo, quantity_unit(q))} to {format_quantity(hi, quantity_unit(q))})" for q, (lo, hi) in result.logged.items())
        if result.log:
            lines.append(f"indices of log10 of each quantity (--log): {spans}")
        else:
            lines.append(
                f"indices of log10 of {spans}: each spans more than a decade over the samples, so its indices are of its relative changes, "
                "which a few extreme samples do not dominate (--no-log keeps every quantity linear)"
            )
    return lines


def write_sensitivity(result: SensitivityResult, out: Path, title: str, where: str) -> list[Path]:
    """``sensitivity.csv`` (SI, units row) and ``sensitivity.html`` (bars and the table) in ``out``
    (claimed as a sensitivity study's folder: :func:`hisopt.folders.claim` refuses another kind's)."""
    from hisopt.folders import SENSITIVITY, claim

    claim(out, SENSITIVITY)
    frame = result.indices
    units = {"S1": "-", "S1_conf": "-", "ST": "-", "ST_conf": "-", "quantity": "", "unit": "", "input": "", "input_unit": "", "distribution": ""}
    csv = write_csv(frame, out / SENSITIVITY_FILES[0], units)
    meta = html.escape(f"{where} (SALib Saltelli sample, bootstrap 95 % half-widths)")
    notes = sensitivity_notes(result) + ([f"{result.dropped} sample blocks dropped where the model failed"] if result.dropped else [])
    meta += "".join(f"<br>{html.escape(line)}" for line in notes)
    figures = PageFigures()
    body = _figure(sensitivity_figure(frame, "Sobol indices: total (ST) and first order (S1)"), figures, "indices")
    body += html_table(total_indices_shown(frame), "Total Sobol index ST of each input on each quantity (± 95 % half-width)", text_columns=("input",))
    body += html_table(sensitivity_shown(frame), "Every index, with the input's distribution", text_columns=("quantity", "input", "distribution"))
    page = atomic_write_text(out / SENSITIVITY_FILES[1], _page(title, meta, body, figures))
    return [csv, page]


def tolerance_shown(summary: pd.DataFrame) -> pd.DataFrame:
    """The Monte Carlo summary for reading: each quantity's statistics in its engineering unit."""
    rows = []
    for r in summary.to_dict("records"):
        unit = r["unit"]
        fmt = lambda v, unit=unit: format_quantity(v, unit)  # noqa: E731
        rows.append(
            {
                "quantity": r["quantity"],
                "nominal": fmt(r["nominal"]),
                "mean": f"{fmt(r['mean'])} ± {format_quantity(r['mean_half_width'], unit)}",
                "sd": fmt(r["sd"]),
                "p5": fmt(r["p5"]),
                "p50": fmt(r["p50"]),
                "p95": fmt(r["p95"]),
                "failed": str(r["failed"]),
            }
        )
    return pd.DataFrame(rows)


def violations_shown(table: pd.DataFrame) -> pd.DataFrame:
    """Each constraint's probability of violation with its interval, for reading."""
    return pd.DataFrame(
        {
            "constraint": table["constraint"],
            "limit": [format_quantity(v, u) for v, u in zip(table["limit"], table["unit"], strict=True)],
            "P(violated)": [f"{p:.4g}" for p in table["probability"]],
            "95 % interval": [f"{lo:.4g} to {hi:.4g}" for lo, hi in zip(table["low"], table["high"], strict=True)],
        }
    )


def write_tolerance(result: ToleranceResult, out: Path, title: str, where: str, limits: dict[str, float], inputs: pd.DataFrame) -> list[Path]:
    """``tolerance.csv``, ``violations.csv`` (SI, each row's unit in its ``unit`` column), ``samples.parquet`` (every
    sample's inputs and quantities, SI) and ``tolerance.html`` in ``out``; ``inputs`` lists
    what varies (``input``, ``distribution``). ``out`` is claimed as a tolerance study's folder
    (:func:`hisopt.folders.claim` refuses another kind's)."""
    from hisopt.folders import TOLERANCE, claim

    claim(out, TOLERANCE)
    summary = result.summary
    # one quantity per row, each in the SI unit its "unit" column names (no units row: it differs by row)
    csv = write_csv(summary, out / TOLERANCE_FILES[0], {})
    viol = write_csv(result.violations, out / TOLERANCE_FILES[1], {})
    samples = out / TOLERANCE_FILES[2]
    result.values.to_parquet(samples, index=False)
    quantities = list(summary["quantity"])
    units = dict(zip(summary["quantity"], summary["unit"], strict=True))
    meta = html.escape(f"{where}; {len(result.values)} Monte Carlo samples, seed {result.seed}; statistics over the samples the model could evaluate")
    body = html_table(inputs, "What varies", text_columns=tuple(inputs.columns))
    body += html_table(tolerance_shown(summary), "Each quantity over the samples (mean ± its 95 % half-width)", text_columns=("quantity",))
    if len(result.violations):
        body += html_table(violations_shown(result.violations), "Probability of violating each constraint (Wilson 95 % interval)", text_columns=("constraint",))
    nominal = dict(zip(summary["quantity"], summary["nominal"], strict=True))
    figures = PageFigures()
    title_spread = "Spread of each quantity (dashed: the nominal design; red: the constraint's limit)"
    spread = tolerance_figure(result.values, quantities, units, limits, nominal, title_spread)
    body += _figure(spread, figures, "spread")
    page = atomic_write_text(out / TOLERANCE_FILES[3], _page(title, meta, body, figures))
    return [csv, viol, samples, page]
