"""``hisopt report RUN_DIR``: one self-contained, offline HTML file of a run."""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import pandas as pd

from hisopt.errors import RunError
from hisopt.io import read_csv

RUN_FILES = {"front": "front.csv", "refined": "front_refined.csv", "generations": "generations.csv", "run": "run.json"}


def load_run_files(run_dir: str | Path) -> dict[str, Any]:
    """The run's record, front (and refined front, generations if present) and problem copy."""
    from hisopt.problem import load_problem, problem_from_dict

    run_dir = Path(run_dir)
    record_path = run_dir / RUN_FILES["run"]
    if not record_path.is_file():
        raise RunError(f"{run_dir}: not a run directory (no run.json); start one with `hisopt optimize`")
    record = json.loads(record_path.read_text(encoding="utf-8"))
    front_path = run_dir / RUN_FILES["front"]
    if not front_path.is_file():
        raise RunError(f"{front_path}: missing; the run has not finished a generation yet")
    copy = run_dir / record["problem"]["copy"]
    problem = load_problem(copy) if copy.suffix == ".toml" else problem_from_dict(json.loads(copy.read_text()), str(copy))
    out: dict[str, Any] = {"record": record, "problem": problem, "front": read_csv(front_path)}
    for key in ("refined", "generations"):
        path = run_dir / RUN_FILES[key]
        out[key] = read_csv(path) if path.is_file() else None
    return out


def _settings_frame(record: dict[str, Any]) -> pd.DataFrame:
    rows = []
    for key, value in record.get("settings", {}).items():
        rows.append(("setting", key, json.dumps(value) if isinstance(value, (list, dict)) else value))
    for key, value in record.get("timings", {}).items():
        rows.append(("timing", key, value))
    for key in ("generations", "evaluations", "front_size", "hypervolume"):
        if key in record.get("result", {}):
            rows.append(("result", key, record["result"][key]))
    rows.append(("problem", "sha256", record["problem"]["sha256"][:16]))
    for key, value in record.get("versions", {}).items():
        rows.append(("version", key, value))
    return pd.DataFrame(rows, columns=["group", "item", "value"])


def build_report(run_dir: str | Path, color_by: str | None = None, design: str = "knee") -> Path:
    """Write ``RUN_DIR/report.html`` and return its path.

    Parameters
    ----------
    color_by : objective colouring the parallel coordinates (default: the first objective)
    design : design whose spectra and modes are shown: ``knee``, ``asf`` or a front row index
    """
    import plotly.offline

    from hisopt.io import atomic_write_text
    from hisopt.modal import modal_analysis
    from hisopt.optim.decision import asf_index, knee_index
    from hisopt.report import figures
    from hisopt.spectra import response_spectra

    run_dir = Path(run_dir)
    run = load_run_files(run_dir)
    problem, front = run["problem"], run["front"]
    objectives, variables = list(problem.objective_names), list(problem.variable_names)
    color_by = color_by or objectives[0]
    if color_by not in front.columns:
        from hisopt.errors import ConfigError

        raise ConfigError(f"unknown column {color_by!r}; expected one of {', '.join(objectives)}", key="--color-by")
    if not len(front):
        raise RunError(f"{run_dir}: the front is empty (no feasible design yet)")
    f = front[objectives].to_numpy()
    knee = front.iloc[knee_index(f)]
    asf = front.iloc[asf_index(f)]
    if design == "knee":
        chosen, chosen_label = knee, "knee"
    elif design == "asf":
        chosen, chosen_label = asf, "ASF pick"
    else:
        try:
            chosen, chosen_label = front.iloc[int(design)], f"front row {int(design)}"
        except (ValueError, IndexError):
            from hisopt.errors import ConfigError

            raise ConfigError(f"expected knee, asf or a row index below {len(front)}, got {design!r}", key="--design") from None
    x = chosen[variables].to_numpy(dtype=float)

    modes_ref = modal_analysis(problem, x, his=False)[["mode", "motion", "frequency_hz", "damping_ratio"]]
    modes_his = modal_analysis(problem, x)[["mode", "frequency_hz", "damping_ratio"]]
    modes = modes_ref.merge(modes_his, on="mode", suffixes=(" without HIS", " with HIS"))
    highlights = {"knee": knee, "ASF pick": asf}
    sections = [
        ("Pareto front", figures.front_scatter_matrix(front, objectives, variables, highlights, run["refined"])),
        ("Designs and objectives", figures.parallel_coordinates(front, variables, objectives, color_by)),
        (f"Response spectra of the {chosen_label} design against the car without HIS", response_spectra(problem, x).plot()),
        (f"Modes of the {chosen_label} design", figures.table_figure(modes, "Modes without and with HIS (paper Table 1)")),
        ("Highlighted designs", figures.table_figure(pd.DataFrame([knee, asf], index=["knee", "ASF pick"]).reset_index(names="design"), "Knee and ASF pick")),
    ]
    if run["generations"] is not None:
        sections.insert(2, ("Convergence", figures.convergence(run["generations"])))
    sections.append(("Run settings and timings", figures.table_figure(_settings_frame(run["record"]), "Settings, timings, versions")))

    parts = []
    for i, (title, fig) in enumerate(sections):
        parts.append(f"<h2>{html.escape(title)}</h2>")
        parts.append(fig.to_html(full_html=False, include_plotlyjs=False, div_id=f"fig{i}"))
    refined_note = "" if run["refined"] is None else f", refined front of {len(run['refined'])} designs"
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>hisopt report: {html.escape(problem.name)}</title>
<style>body{{font-family:Inter,Helvetica,Arial,sans-serif;margin:24px auto;max-width:1280px;color:#1d2330}}
h1{{margin-bottom:4px}} h2{{margin-top:36px;border-bottom:1px solid #e3e6ea}} .meta{{color:#556}}</style>
<script type="text/javascript">{plotly.offline.get_plotlyjs()}</script></head>
<body><h1>hisopt report: {html.escape(problem.name)}</h1>
<p class="meta">{html.escape(str(run_dir))}: front of {len(front)} designs{refined_note};
objectives {html.escape(", ".join(objectives))}; knee and ASF pick highlighted.</p>
{''.join(parts)}
</body></html>"""
    out = run_dir / "report.html"
    atomic_write_text(out, page)
    return out
