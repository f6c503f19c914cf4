"""The buildability verdict where a run is read (docs/model.md §21.3): the optimise summary,
the run report and the decision room show each design's ``buildable``, ``binding_rule`` and
``build_margin`` (:func:`hisopt.studies.buildability.buildability`), whether or not the
problem enforces the rules as constraints.

On a large front the verdict costs tens of seconds (every rule in every load case, the
damper valves' fixed point and the wheel modes included), so ``hisopt optimize`` and
``hisopt resume`` compute it once, when the run finishes, and store it beside the front as
``buildability.csv`` (:func:`write_run_verdicts`); the views read it back
(:func:`run_verdicts`) and compute only the designs it does not hold: a run finished before
the file existed, a refined front, the decision room's other evaluations. A reader never
writes into a finished run.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.buildability import RULES
from hisopt.studies.buildability import BINDING_RULE, BUILD_MARGIN, BUILDABLE, VERDICT_COLUMNS, buildability
from hisopt.units import NO_UNIT, variable_units

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

BUILDABILITY_CSV = "buildability.csv"
"""A finished run's verdicts, one row per row of ``front.csv``: the variables [SI] (so that a
reader can tell the file belongs to the front beside it), each rule's largest usage over the
load cases and :data:`~hisopt.studies.buildability.VERDICT_COLUMNS`."""
FAILING_SHOWN = 3
"""Rules named where no design is buildable: the commonest failures."""
VERDICT_NOTE = (
    "buildable: every buildability rule (docs/model.md §21) within its limit in every load case, constrained or not; "
    "binding_rule: the rule with the largest usage; build_margin: 1 minus that usage"
)
"""What the verdict's rows mean, where a table shows them."""


# --- the verdicts of designs, stored ones reused ---------------------------------------------
def verdicts_of(problem: DesignSpace, x: np.ndarray, stored: pd.DataFrame | None = None) -> pd.DataFrame:
    """The verdicts (rules' usages and :data:`VERDICT_COLUMNS`) of designs ``x`` [SI] ``(n,
    n_var)`` of ``problem``, one row each: a row of ``stored`` (a :data:`BUILDABILITY_CSV`
    table) with the same variables bit for bit where there is one, else computed."""
    names = list(problem.variable_names)
    x = np.asarray(x, dtype=float).reshape(-1, len(names))
    columns = [*RULES, *VERDICT_COLUMNS]
    found = np.full(len(x), -1)
    if stored is not None and set(names) <= set(stored.columns) and set(columns) <= set(stored.columns):
        index = {tuple(v): k for k, v in enumerate(stored[names].to_numpy(dtype=float))}
        found = np.array([index.get(tuple(v), -1) for v in x], dtype=int)
    out = pd.DataFrame(index=range(len(x)), columns=columns)
    known = found >= 0
    if known.any():
        out.loc[known, columns] = stored.iloc[found[known]][columns].to_numpy()  # type: ignore[union-attr]
    if (~known).any():
        fresh = buildability(problem, x[~known])
        out.loc[~known, columns] = fresh[columns].to_numpy()
    out[list(RULES) + [BUILD_MARGIN]] = out[list(RULES) + [BUILD_MARGIN]].astype(float)
    out[BUILDABLE] = out[BUILDABLE].map(_truth).astype(bool)
    out[BINDING_RULE] = out[BINDING_RULE].fillna("").astype(str)
    out.attrs["units"] = dict.fromkeys(out.columns, NO_UNIT)
    return out


def _truth(value: Any) -> bool:
    """A stored ``buildable`` cell (``True``, ``"True"``) as a bool."""
    return value is True or str(value).strip().lower() == "true"


def stored_verdicts(run_dir: str | Path) -> pd.DataFrame | None:
    """``RUN_DIR/buildability.csv``, or None where the run has none (or it cannot be read)."""
    from hisopt.io import read_csv

    path = Path(run_dir) / BUILDABILITY_CSV
    if not path.is_file():
        return None
    try:
        return read_csv(path, keep_default_na=False, na_values=[""], dtype={BINDING_RULE: str})
    except (OSError, ValueError, pd.errors.ParserError):
        return None  # computed again: the file is a cache of the front's verdicts


def run_verdicts(run_dir: str | Path | None, problem: DesignSpace, x: np.ndarray) -> pd.DataFrame:
    """:func:`verdicts_of` designs ``x`` of the run in ``run_dir`` (None: none stored),
    reusing its :data:`BUILDABILITY_CSV`; nothing is written."""
    return verdicts_of(problem, x, None if run_dir is None else stored_verdicts(run_dir))


def write_run_verdicts(run_dir: str | Path, problem: DesignSpace, front: pd.DataFrame) -> pd.DataFrame:
    """Compute the verdicts of ``front`` (a run's ``front.csv``) and write them to
    ``RUN_DIR/buildability.csv`` atomically; the verdicts."""
    from hisopt.io import write_csv

    names = list(problem.variable_names)
    verdicts = run_verdicts(run_dir, problem, front[names].to_numpy(dtype=float))  # a resumed run's unchanged rows reused
    table = pd.concat([front[names].reset_index(drop=True), verdicts], axis=1)
    write_csv(table, Path(run_dir) / BUILDABILITY_CSV, variable_units(problem) | verdicts.attrs["units"])
    return verdicts


# --- in words -------------------------------------------------------------------------------
def failing_rules(verdicts: pd.DataFrame, shown: int = FAILING_SHOWN) -> list[tuple[str, int]]:
    """The ``shown`` rules designs break most often (usage above 1 in some load case), each
    with how many designs break it; ``("not evaluated", n)`` for designs with no verdict."""
    counts = {name: int((verdicts[name].to_numpy(dtype=float) > 1.0).sum()) for name in RULES}
    unknown = int((verdicts[BINDING_RULE] == "").sum())  # a NaN usage
    if unknown:
        counts["not evaluated"] = unknown
    ranked = sorted((item for item in counts.items() if item[1]), key=lambda item: -item[1])
    return ranked[:shown]


def buildable_line(verdicts: pd.DataFrame, what: str = "front designs") -> str:
    """``"12 of 40 front designs buildable"``, or, when none is, ``"none of 40 front designs
    buildable; failing most often: strut_load_usage (40), ..."``."""
    n, ok = len(verdicts), int(verdicts[BUILDABLE].sum())
    if ok or not n:
        return f"{ok} of {n} {what} buildable"
    failing = ", ".join(f"{name} ({count})" for name, count in failing_rules(verdicts))
    return f"none of {n} {what} buildable; failing most often: {failing}"


def margin_text(margin: float) -> str:
    """[%] A build margin as a signed percentage (``+12.5``, ``-3.0``; ``-inf`` beyond a limit
    of zero), ``-`` without one."""
    if np.isnan(margin):
        return "-"
    if np.isinf(margin):
        return f"{margin:+}"
    return f"{100.0 * margin + 0.0:+.1f}"  # + 0.0: no "-0.0"


def verdict_cells(verdict: Mapping[str, Any]) -> dict[str, str]:
    """A design's verdict as the tables show it: ``buildable`` (``yes``/``no``), the binding
    rule and the margin in percent (``build_margin [%]``)."""
    rule = str(verdict[BINDING_RULE])
    return {
        BUILDABLE: "yes" if bool(verdict[BUILDABLE]) else ("no" if rule else "no (not evaluated)"),
        BINDING_RULE: rule or "-",
        f"{BUILD_MARGIN} [%]": margin_text(float(verdict[BUILD_MARGIN])),
    }


def verdict_rows(problem: DesignSpace, picks: Mapping[str, Mapping[str, Any]], stored: pd.DataFrame | None) -> list[tuple[str, tuple[str, ...]]]:
    """The rows ``buildable``, ``binding_rule`` and ``build_margin [%]`` of the named designs
    ``picks`` (a design: its variables by name, e.g. a front row), one cell per design, from
    ``stored`` verdicts where they hold the design (:func:`verdicts_of`)."""
    names = list(problem.variable_names)
    x = np.array([[float(d[n]) for n in names] for d in picks.values()])
    verdicts = verdicts_of(problem, x, stored)
    cells = [verdict_cells(verdicts.iloc[k]) for k in range(len(picks))]
    return [(label, tuple(c[label] for c in cells)) for label in cells[0]]


def with_variables(problem: DesignSpace, designs: pd.DataFrame, verdicts: pd.DataFrame) -> pd.DataFrame:
    """``verdicts`` of ``designs`` (rows in the same order) beside their variables: the form
    :func:`verdicts_of` looks designs up in."""
    names = list(problem.variable_names)
    return pd.concat([designs[names].reset_index(drop=True), verdicts.reset_index(drop=True)], axis=1)
