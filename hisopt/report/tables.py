"""The reports' HTML tables and style sheet, shared by the run report, the design sheet and
the layout study's report: tables of strings in engineering units, which size to their
content, wrap instead of clipping and copy into a spreadsheet."""

from __future__ import annotations

import html
from typing import Any

import pandas as pd

REPORT_CSS = """
body{font-family:Inter,Helvetica,Arial,sans-serif;margin:24px auto;max-width:1280px;padding:0 16px;color:#1d2330}
h1{margin-bottom:4px} h2{margin-top:40px;margin-bottom:12px;border-bottom:1px solid #e3e6ea;padding-bottom:4px}
.meta{color:#556;line-height:1.5}
.figure{margin:0 0 8px 0;overflow-x:auto}
table.data{border-collapse:collapse;font-size:14px;margin:8px 0 4px 0;font-variant-numeric:tabular-nums}
table.data caption{caption-side:top;text-align:left;font-weight:600;padding:0 0 6px 0;color:#1d2330}
table.data th,table.data td{padding:5px 12px;border-bottom:1px solid #e3e6ea;text-align:right;white-space:nowrap}
table.data th{background:#eef1f5;font-weight:600;vertical-align:bottom}
table.data th .unit{display:block;font-weight:400;color:#556}
table.data td.text,table.data th.text{text-align:left}
table.data td.wrap{white-space:normal;max-width:640px;overflow-wrap:anywhere}
table.data tbody tr:nth-child(even){background:#fafbfc}
p.note{color:#556;font-size:13px;margin:4px 0 0 0}
"""


def html_table(shown: pd.DataFrame, caption: str = "", text_columns: tuple[str, ...] = (), wrap_columns: tuple[str, ...] = ()) -> str:
    """An HTML table of strings; a header ``name [unit]`` shows the unit on a line of its own.

    Parameters
    ----------
    shown : pd.DataFrame
        cells as text (e.g. :func:`hisopt.units.display_frame`)
    text_columns : tuple[str, ...], optional
        left-aligned columns (labels); numbers are right-aligned
    wrap_columns : tuple[str, ...], optional
        columns whose long text wraps
    """

    def header(col: str) -> str:
        name, sep, unit = col.partition(" [")
        cls = ' class="text"' if col in text_columns else ""
        unit_html = f'<span class="unit">[{html.escape(unit)}</span>' if sep else ""
        return f"<th{cls}>{html.escape(name)}{unit_html}</th>"

    def cell(col: str, value: Any) -> str:
        classes = " ".join(c for c, on in (("text", col in text_columns), ("wrap", col in wrap_columns)) if on)
        return f"<td{f' class={chr(34)}{classes}{chr(34)}' if classes else ''}>{html.escape(str(value))}</td>"

    head = "".join(header(str(c)) for c in shown.columns)
    body = "".join("<tr>" + "".join(cell(str(c), v) for c, v in zip(shown.columns, row, strict=True)) + "</tr>" for row in shown.itertuples(index=False))
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<table class="data">{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'
