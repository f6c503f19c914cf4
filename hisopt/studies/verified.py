"""The time-domain verifications of a run's designs, as ``hisopt verify`` leaves them
(docs/model.md §22.5): ``RUN_DIR/verify-N/verify.json`` (a summary) and ``verify.csv`` (every
figure, SI, a units row) for front row ``N``.

The decision room and the design sheet read them here, and only here: one format check, one
refusal in one line (:class:`~hisopt.errors.RunError`) for a file that is not what
``hisopt verify`` writes.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hisopt.errors import ConfigError, RunError
from hisopt.simulation.verification_rows import ROW_COLUMNS
from hisopt.studies.verify_designs import SUMMARY_FORMAT as VERIFY_FORMAT  # the writer's: one format
from hisopt.studies.verify_designs import VERIFY_CSV, VERIFY_JSON

VERIFY_PREFIX = "verify-"
"""``RUN_DIR/verify-N``: the verification of front row ``N``."""
VERDICTS = ("agrees", "gap", "beyond limit", "outside validity")
"""A design's verdicts (:attr:`hisopt.simulation.verification.Verification.verdict`)."""
SUMMARY_KEYS: dict[str, type | tuple[type, ...]] = {
    "problem": str,
    "design": str,
    "verdict": str,
    "values": dict,
    "realisations": dict,
    "duration_s": (int, float),
    "settle_s": (int, float),
    "seed": int,
    "notes": list,
}
"""The keys a summary holds beside ``format`` and ``row``, and their JSON types."""


def verify_folder(run_dir: str | Path, row: int) -> Path:
    """``RUN_DIR/verify-N``: where ``hisopt verify RUN_DIR --design N`` writes."""
    return Path(run_dir) / f"{VERIFY_PREFIX}{int(row)}"


def _refuse(path: Path, what: str) -> RunError:
    return RunError(f"{path}: {what}; expected the summary `hisopt verify` writes ({VERIFY_FORMAT}): run it again")


def read_verification_summary(folder: str | Path) -> dict[str, Any]:
    """The summary ``folder/verify.json`` (``format``, ``problem``, ``design``, ``row`` (int or
    None), ``verdict``, ``values`` [SI], ``realisations`` per load case, ``duration_s``,
    ``settle_s``, ``seed``, ``notes``), checked.

    Raises
    ------
    RunError
        the file is missing, not JSON, of another format, or lacks a key or has one of the
        wrong type (one line naming the file and the key).
    """
    path = Path(folder) / VERIFY_JSON
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RunError(f"{path}: missing; expected a folder written by `hisopt verify`") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise _refuse(path, f"unreadable ({type(exc).__name__})") from None
    if not isinstance(data, dict):
        raise _refuse(path, f"a JSON {type(data).__name__}, not an object")
    if data.get("format") != VERIFY_FORMAT:
        raise _refuse(path, f"format {data.get('format')!r}")
    for key, kind in SUMMARY_KEYS.items():
        if key not in data:
            raise _refuse(path, f"no key {key!r}")
        if not isinstance(data[key], kind) or isinstance(data[key], bool):
            raise _refuse(path, f"key {key!r} is {data[key]!r}")
    row = data.get("row")
    if row is not None and (not isinstance(row, int) or isinstance(row, bool) or row < 0):
        raise _refuse(path, f"key 'row' is {row!r}, not a front row (a whole number >= 0) or null")
    if data["verdict"] not in VERDICTS:
        raise _refuse(path, f"verdict {data['verdict']!r}, not one of {', '.join(VERDICTS)}")
    if not all(isinstance(r, int) and not isinstance(r, bool) for r in data["realisations"].values()):
        raise _refuse(path, "key 'realisations' is not a whole number per load case")
    if not all(isinstance(n, str) for n in data["notes"]):
        raise _refuse(path, "key 'notes' is not a list of sentences")
    return data


def read_verification_rows(folder: str | Path) -> pd.DataFrame:
    """``folder/verify.csv``: one row per load case and figure (:data:`~hisopt.simulation.verification_rows.ROW_COLUMNS`), SI,
    each row's unit in ``unit``; ``cause`` ``""`` where a figure has none.

    Raises
    ------
    RunError
        the file is missing, unreadable or lacks a column (one line naming it).
    """
    from hisopt.io import read_csv

    path = Path(folder) / VERIFY_CSV
    if not path.is_file():
        raise RunError(f"{path}: missing; expected a folder written by `hisopt verify`")
    try:
        frame = read_csv(path, keep_default_na=False, na_values=[""])
    except ConfigError as exc:
        raise RunError(f"{path}: {exc.args[0] if exc.args else 'unreadable'}; expected the table `hisopt verify` writes") from None
    missing = [c for c in ROW_COLUMNS if c not in frame.columns]
    if missing:
        raise RunError(f"{path}: no column {missing[0]!r}; expected the table `hisopt verify` writes ({', '.join(ROW_COLUMNS)})")
    for column in ("case", "figure", "unit", "verdict", "cause"):
        frame[column] = ["" if isinstance(v, float) and math.isnan(v) else str(v) for v in frame[column]]
    numeric = [c for c in ROW_COLUMNS if c not in ("case", "figure", "unit", "verdict", "cause")]
    try:
        frame[numeric] = frame[numeric].astype(float)
    except (TypeError, ValueError):
        raise RunError(f"{path}: a figure's value is not a number; expected the table `hisopt verify` writes") from None
    return frame


@dataclass(frozen=True)
class VerifiedDesign:
    """A design's verification as ``hisopt verify`` left it: its folder, its summary
    (:func:`read_verification_summary`) and its figures (:func:`read_verification_rows`)."""

    folder: Path
    summary: dict[str, Any]
    rows: pd.DataFrame


def read_verification(folder: str | Path) -> VerifiedDesign:
    """The :class:`VerifiedDesign` in ``folder`` (both files checked; :class:`RunError` otherwise)."""
    return VerifiedDesign(Path(folder), read_verification_summary(folder), read_verification_rows(folder))


def verified_rows(run_dir: str | Path | None) -> dict[int, dict[str, Any]]:
    """The summary of every verified front row of a run: ``{row: summary}`` from each
    ``RUN_DIR/verify-*/verify.json`` whose ``row`` is set (a folder without a summary, or
    verifying a design that is no front row, is left out); ``{}`` for None.

    Raises
    ------
    RunError
        a summary is malformed (:func:`read_verification_summary`).
    """
    if run_dir is None:
        return {}
    out: dict[int, dict[str, Any]] = {}
    for path in sorted(Path(run_dir).glob(f"{VERIFY_PREFIX}*/{VERIFY_JSON}")):
        summary = read_verification_summary(path.parent)
        if summary["row"] is not None:
            out[int(summary["row"])] = summary
    return out


def same_design(values: dict[str, Any], names: list[str], design: np.ndarray) -> bool:
    """Whether a summary's ``values`` [SI] are ``design`` (``names`` its variables), to
    round-trip precision (JSON's shortest decimals read back exactly; 1e-12 relative spares
    a writer that rounded in its last digit)."""
    try:
        mine = np.array([float(values[n]) for n in names])
    except (KeyError, TypeError, ValueError):
        return False
    return bool(np.allclose(mine, np.asarray(design, dtype=float), rtol=1e-12, atol=0.0))


def front_verdicts(run_dir: str | Path | None, names: list[str], x: np.ndarray, kind: np.ndarray, row: np.ndarray) -> np.ndarray:
    """[-] Each design's verdict in the time domain, ``""`` where it was not verified: a front
    row's (``kind == "front"``, ``row`` its row) from its summary (:func:`verified_rows`)
    when the summary's values are the row's design (a summary of an earlier front, before the
    run was resumed, is not this row's); ``names`` the variables of ``x`` ``(n, n_var)`` [SI].

    Raises
    ------
    RunError
        a summary is malformed (:func:`read_verification_summary`).
    """
    summaries = verified_rows(run_dir)
    out = np.full(len(x), "", dtype=object)
    for i, (design, k, r) in enumerate(zip(x, kind, row, strict=True)):
        summary = summaries.get(int(r)) if k == "front" else None
        if summary is not None and same_design(summary["values"], names, design):
            out[i] = summary["verdict"]
    return out
