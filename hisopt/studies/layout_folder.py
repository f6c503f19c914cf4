"""A layout study's directory read back: ``hisopt status`` and ``hisopt report`` on it.

A study directory (:mod:`hisopt.studies.layout_study`) holds ``study.json``, one run directory
per layout and seed (``<layout>/seed-<n>/``) and, once the study has finished, its tables
and ``report.html``. :func:`study_status` says in a few lines what state it is in and what
to do next; :func:`read_layout_study` rebuilds the study's result from its files (the
tables, the normalisation in ``study.json`` and each layout's problem from its runs' own
copies), so that :func:`hisopt.report.layout_report.write_layout_report` can write the
report again without running anything.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from hisopt.errors import RunError
from hisopt.optim import rundir
from hisopt.optim.runstate import FAILED, FINISHED, RUNNING, STARTING, read_state
from hisopt.studies.layout_cases import CONVENTIONAL, REFERENCE_LAYOUT, LayoutCase
from hisopt.studies.layout_study import (
    ATTAINMENT_CSV,
    CURVE_CSV,
    FRONTS_CSV,
    LAYOUTS_CSV,
    RUNS_CSV,
    STUDY_FORMAT,
    STUDY_JSON,
    LayoutStudyResult,
    problem_digest,
)

REPORT_HTML = "report.html"
TABLES = (LAYOUTS_CSV, RUNS_CSV, FRONTS_CSV, CURVE_CSV, ATTAINMENT_CSV)
_SEED_DIR = re.compile(r"seed-(\d+)")


def is_layout_study(path: str | Path) -> bool:
    """[-] Whether ``path`` is a directory holding a layout study's ``study.json``."""
    try:
        record = json.loads((Path(path) / STUDY_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(record, dict) and record.get("format") == STUDY_FORMAT


def _record(out: Path) -> dict[str, Any]:
    if not is_layout_study(out):
        raise RunError(f"{out}: not a layout study (no readable {STUDY_JSON}); expected the --out directory of `hisopt compare-layouts`")
    return json.loads((out / STUDY_JSON).read_text(encoding="utf-8"))


def _seeds(out: Path, record: dict[str, Any]) -> dict[str, list[int]]:
    """[-] Per layout of the record, the seeds of its run directories (sorted)."""
    found = {}
    for name in record.get("layouts", {}):
        folder = out / name
        seeds = [int(m.group(1)) for p in folder.iterdir() if (m := _SEED_DIR.fullmatch(p.name)) and p.is_dir()] if folder.is_dir() else []
        found[name] = sorted(seeds)
    return found


def seed_text(seeds: list[int]) -> str:
    """``[1, 2, 3]`` -> ``"1-3"``; otherwise comma-separated (what ``--seeds`` takes)."""
    if len(seeds) > 1 and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}-{seeds[-1]}"
    return ",".join(map(str, seeds))


def _command(out: Path, record: dict[str, Any], seeds: list[int]) -> str:
    """The ``hisopt compare-layouts`` command that resumes (or finishes) the study, in
    backticks, and what it cannot know."""
    path = record["problem"].get("path")
    layouts = ",".join(source if source != "catalogue" else name for name, source in record["layouts"].items())
    budget = record["budget"]
    problem = path if path and Path(path).is_file() else "PROBLEM"
    text = (
        f"hisopt compare-layouts {problem} --layouts {layouts} --seeds {seed_text(seeds) or 'SEEDS'} --pop {budget['pop_size']} "
        f"--gens {budget['generations']} --out {out}"
    )
    unknown = [] if seeds else ["SEEDS: the seeds you gave (no run has begun)"]
    if (out / LAYOUTS_CSV).is_file():
        from hisopt.io import read_csv

        table = read_csv(out / LAYOUTS_CSV)
        text += f" --handling {table['handling'].iloc[0]} --handling-limit {float(table['handling_limit'].iloc[0])!r}"
    else:
        unknown.append("add the --handling and --handling-limit you gave, if any")
    return f"`{text}`" + (f" ({'; '.join(unknown)})" if unknown else "")


def _problem_note(record: dict[str, Any]) -> str:
    """Why the recorded problem file cannot resume the study, or "" when it can."""
    from hisopt.errors import ConfigError
    from hisopt.problem import load_problem

    path = record["problem"].get("path")
    digest = record["problem"]["sha256"]
    if not path or not Path(path).is_file():
        where = f", not found at {path}" if path else ""
        return f"PROBLEM: the study's problem file {record['problem']['name']!r} (sha256 {digest[:12]}){where}"
    try:
        now = problem_digest(load_problem(path))
    except ConfigError as exc:
        return f"{path} no longer loads ({exc})"
    if now != digest:
        return f"{path} has changed since the study began (sha256 {digest[:12]} -> {now[:12]}): the study refuses it; restore it"
    return ""


def _run_text(run_dir: Path) -> tuple[str, str]:
    """(state, one phrase) of one run of a study."""
    if not (run_dir / rundir.RUN_JSON).is_file():
        return "missing", "not started"
    try:
        state = read_state(run_dir)
    except (RunError, OSError, ValueError, KeyError) as exc:
        return "unknown", f"state unknown ({exc})"
    g, n = state.generation, state.generations
    if state.status == FINISHED:
        return FINISHED, f"finished, {g} of {n} generations"
    if state.status in (STARTING, RUNNING) and state.alive is not False:
        pid = (state.info.get("process") or {}).get("pid")
        return RUNNING, f"running in process {pid}, {g} of {n} generations saved"
    if state.status == FAILED:
        return FAILED, f"failed after {g} of {n} generations ({state.failure.get('error', 'unknown error')})"
    return state.status, f"{state.status} after {g} of {n} generations"


def study_status(out: str | Path) -> list[str]:
    """Lines for ``hisopt status`` on a study directory: what it holds, each run's state,
    whether its tables and report exist, and what to do next.

    Raises
    ------
    RunError
        ``out`` is not a layout study.
    """
    out = Path(out)
    record = _record(out)
    seeds = _seeds(out, record)
    every = sorted({s for found in seeds.values() for s in found})
    budget = record["budget"]
    lines = [
        f"{out}: layout study of {record['problem']['name']}: layouts {', '.join(seeds)}; seeds {seed_text(every) or 'none yet'}; "
        f"runs of population {budget['pop_size']} for {budget['generations']} generations"
    ]
    states = []
    for name in seeds:
        for s in every:
            state, text = _run_text(out / name / f"seed-{s}")
            states.append(state)
            lines.append(f"  {name} seed {s}: {text}")
    written = {name: (out / name).is_file() for name in (*TABLES, REPORT_HTML)}
    files = {
        (True, True): f"{LAYOUTS_CSV} and {REPORT_HTML} written",
        (True, False): f"{LAYOUTS_CSV} written, no {REPORT_HTML} yet",
        (False, True): f"{REPORT_HTML} written, {LAYOUTS_CSV} missing",
        (False, False): f"no {LAYOUTS_CSV} or {REPORT_HTML} yet",
    }
    lines.append(f"  {files[written[LAYOUTS_CSV], written[REPORT_HTML]]}")
    if RUNNING in states:
        lines.append(f"next: wait for the running runs, then `hisopt status {out}` again")
    elif not every or any(s != FINISHED for s in states) or not all(written[n] for n in TABLES):
        note = _problem_note(record)
        lines.append(f"next: finish the study (finished runs are reused) with {_command(out, record, every)}" + (f"; {note}" if note else ""))
    elif not written[REPORT_HTML]:
        lines.append(f"next: `hisopt report {out}` writes {out / REPORT_HTML}")
    else:
        lines.append(f"finished: open {out / REPORT_HTML} (the table: {out / LAYOUTS_CSV}); `hisopt report {out}` writes the report again")
    return lines


def read_layout_study(out: str | Path) -> LayoutStudyResult:
    """The result of a finished study, from its files (module docstring).

    Raises
    ------
    RunError
        ``out`` is not a layout study, or not a finished one (a table is missing), or a run's
        problem copy is missing or edited.
    """
    from hisopt.io import read_csv
    from hisopt.studies.layout_metrics import Normalisation

    out = Path(out)
    record = _record(out)
    missing = [name for name in TABLES if not (out / name).is_file()]
    if missing:
        every = sorted({s for found in _seeds(out, record).values() for s in found})
        raise RunError(
            f"{out}: the layout study has no {missing[0]} yet (it has not finished); finish it with {_command(out, record, every)}, which writes the report too"
        )
    table, runs, fronts, curve, attainment = (read_csv(out / name) for name in TABLES)
    handling = str(table["handling"].iloc[0])
    cases = []
    for name in table["layout"]:
        if name == CONVENTIONAL:  # sized, not optimised: no runs (its row is the table's)
            continue
        seed = int(runs.loc[runs["layout"] == name, "seed"].min())
        run_dir = out / name / f"seed-{seed}"
        problem = rundir.load_run_problem(run_dir, rundir.read_run_json(run_dir)["problem"], check_original=False)
        cases.append(LayoutCase(name, problem, record["layouts"].get(name, "catalogue")))
    if cases[0].name != REFERENCE_LAYOUT:
        raise RunError(f"{out / LAYOUTS_CSV}: its first layout is {cases[0].name!r}, not {REFERENCE_LAYOUT}; not a table of hisopt's")
    return LayoutStudyResult(
        table=table,
        runs=runs,
        fronts=fronts,
        curve=curve,
        attainment=attainment,
        cases=cases,
        normalisation=Normalisation.from_json(record["normalisation"][handling]),
        handling=handling,
        handling_limit=float(table["handling_limit"].iloc[0]),
        out=out,
    )
