"""``hisopt verify``: which designs, where their verifications go, and writing them (docs/model.md §22).

A target is a run directory (designs by their ``front.csv`` row, the knee by default; each
verified into ``RUN_DIR/verify-N``) or a problem file (its baseline: a design sheet's
``sheet.toml`` is the design it describes; written into ``--out``). Each design is one task:
in this process, or on Dask with ``--workers``/``--scheduler`` (:func:`verify_designs`).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError, RunError
from hisopt.evaluation.parallel import Backend
from hisopt.io import atomic_write_json, atomic_write_text, write_csv
from hisopt.problem import Problem
from hisopt.simulation.verification import Verification, verify_design
from hisopt.simulation.verification_rows import ROW_COLUMNS, VerifySettings

VERIFY_CSV, VERIFY_JSON, VERIFY_HTML = "verify.csv", "verify.json", "verify.html"
SUMMARY_FORMAT = "hisopt-verify/1"
"""The format of ``verify.json``: the summary the decision room and the design sheet read."""


@dataclass(frozen=True)
class Target:
    """One design to verify: its ``front.csv`` row (None for a problem's baseline), its
    variables (SI), its label and the folder it goes to."""

    row: int | None
    x: np.ndarray
    label: str
    folder: Path


def parse_rows(text: str | None) -> list[int] | None:
    """``--design`` as rows: ``"12"`` or ``"3,5,7"`` (None: the knee)."""
    if text is None:
        return None
    rows = []
    for part in str(text).split(","):
        part = part.strip()
        if not part.isdigit():
            raise ConfigError(f"expected front.csv rows from 0, comma-separated (e.g. 12 or 3,5,7), got {text!r}", key="--design")
        rows.append(int(part))
    return list(dict.fromkeys(rows))


def targets(target: Path, rows: list[int] | None, out: Path | None) -> tuple[Problem, list[Target]]:
    """The problem and the designs of ``hisopt verify TARGET`` (module docstring); refuses a
    directory that is not an optimisation run, a row not in its front, or a problem file
    given ``--design``, in one line."""
    from hisopt.folders import RUN, folder_kind

    target = Path(target)
    if target.is_dir():
        found = folder_kind(target)
        if found is None or found.kind.name != RUN:
            what = found.describe(target) if found is not None else f"{target} is not an optimisation run (no run.json)"
            raise RunError(f"{what}; expected a run directory written by hisopt optimize, or a problem file")
        from hisopt.optim.decision import front_design
        from hisopt.optim.rundir import FRONT_CSV, run_problem

        problem, _ = run_problem(target)
        chosen = []
        several = rows is not None and len(rows) > 1
        for row in rows if rows is not None else [None]:
            index, x = front_design(problem, target / FRONT_CSV, row)
            folder = (out if out is not None else target) / f"verify-{index}" if several or out is None else out
            chosen.append(Target(index, x, f"front.csv row {index}", folder))
        return problem, chosen
    if rows is not None:
        raise ConfigError(f"{target} is a problem file: hisopt verify takes its baseline; --design picks rows of a run directory's front", key="--design")
    if out is None:
        raise ConfigError("a problem's baseline needs a folder for its verification; expected --out DIR", key="--out")
    from hisopt.problem import load_problem

    problem = load_problem(target)
    return problem, [Target(None, problem.design_matrix(problem.baseline)[0], "baseline", out)]


def _verify_one(target: Target, problem: Problem, settings: VerifySettings, manoeuvres: bool) -> Verification:
    return verify_design(problem, target.x[None, :], target.label, settings, manoeuvres)


def verify_designs(problem: Problem, chosen: list[Target], settings: VerifySettings, backend: Backend, manoeuvres: bool = True) -> list[Verification]:
    """Verify every design of ``chosen``, one task each on ``backend``, in order."""
    return backend.map(_verify_one, chosen, problem, settings, manoeuvres)


def summary(verification: Verification, row: int | None) -> dict[str, Any]:
    """``verify.json``'s content (:data:`SUMMARY_FORMAT`)."""
    settings = asdict(verification.settings)
    return {
        "format": SUMMARY_FORMAT,
        "problem": verification.problem,
        "design": verification.design,
        "row": row,
        "verdict": verification.verdict,
        "values": verification.values,
        "realisations": {case.traces.case: case.realisations for case in verification.cases},
        "duration_s": verification.settings.duration_s,
        "settle_s": verification.settings.settle_s,
        "seed": verification.settings.seed,
        "settings": {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in settings.items()},
        "notes": list(verification.notes),
    }


ROW_UNITS = {"case": "-", "figure": "-", "unit": "-", "verdict": "-", "cause": "-"} | {
    column: "unit" for column in ROW_COLUMNS if column not in ("case", "figure", "unit", "verdict", "cause", "gap", "gap_se")
}
"""verify.csv's units row: each value in its row's ``unit`` column; gaps relative [-]."""


def write_verification(verification: Verification, folder: Path, row: int | None) -> list[Path]:
    """Write ``verify.csv`` (every figure; manoeuvres as ``<manoeuvre>@<case>`` rows),
    ``verify.json`` (the summary) and ``verify.html`` into ``folder`` (already claimed)."""
    from hisopt.report.verify_page import verify_page

    frame = verification.frame()
    if not verification.manoeuvres.empty:
        m = verification.manoeuvres
        extra = m.assign(case=m["manoeuvre"] + "@" + m["case"], frequency_domain=m["transient"])[
            ["case", "figure", "unit", "frequency_domain", "linear", "nonlinear"]
        ]
        extra = extra.assign(gap=(m["nonlinear"] - m["linear"]) / m["linear"].abs().where(m["linear"] != 0.0), verdict="info", cause="")
        frame = pd.concat([frame, extra.reindex(columns=frame.columns)], ignore_index=True)
    units = ROW_UNITS | {"gap": "-", "gap_se": "-"}
    paths = [write_csv(frame, folder / VERIFY_CSV, units)]
    paths.append(atomic_write_json(folder / VERIFY_JSON, summary(verification, row)))
    paths.append(atomic_write_text(folder / VERIFY_HTML, verify_page(verification)))
    return paths


def read_summary(folder: Path) -> dict[str, Any]:
    """A verification folder's ``verify.json``; :class:`RunError` in one line if unreadable."""
    path = Path(folder) / VERIFY_JSON
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"{path}: unreadable ({exc}); expected a verification written by hisopt verify") from None
    if not isinstance(data, dict) or data.get("format") != SUMMARY_FORMAT:
        raise RunError(f"{path}: not a verification summary (format {SUMMARY_FORMAT!r} expected)")
    return data


__all__ = ["Target", "parse_rows", "read_summary", "summary", "targets", "verify_designs", "write_verification"]
