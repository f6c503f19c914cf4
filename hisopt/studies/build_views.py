"""The buildability verdict as the views show it (docs/model.md §21.3): the design sheet's
section, ``hisopt evaluate --build``'s table of each rule's usage per load case, and the
layout study's and synthesis's verdict of each layout's ranked design.

The numbers are :mod:`hisopt.studies.buildability`'s (every rule, whether or not a problem
enforces it as a constraint); this module only arranges them and says them in words and
engineering units.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.buildability import RULES
from hisopt.studies.buildability import BINDING_RULE, BUILD_MARGIN, BUILDABLE, VERDICT_COLUMNS, CaseRules, buildability, verdicts
from hisopt.units import NO_UNIT, Display, format_number

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

ALL_CASES = "all cases"
"""The ``load_case`` of a design's verdict over every load case in :func:`usage_table` (a
scenario's name has no space, so it never clashes)."""

RULE_DISPLAY: dict[str, Display] = {
    "Pa": Display("MPa", 1e-6),
    "m": Display("mm", 1e3),
    "N": Display("kN", 1e-3),
    "m/s": Display("m/s"),
    "Hz": Display("Hz"),
    NO_UNIT: Display(NO_UNIT),
}
"""How a rule's value and limit are shown, by their SI unit: pressures in MPa, lengths in mm,
forces in kN, ratios bare; every cell reads back as a ``[build]`` value (``"16 MPa"``)."""


def pressure_basis(rule: str) -> str:
    """``abs`` or ``gauge`` for a rule on pressures, as its label says (``""`` otherwise)."""
    found = re.search(r"\((abs|gauge)\)", RULES[rule].label)
    return found.group(1) if found else ""


def usage_columns() -> tuple[str, ...]:
    """The columns of :func:`usage_table`, in order."""
    return ("design", "load_case", *RULES, *VERDICT_COLUMNS)


def usage_table(cases: list[CaseRules]) -> pd.DataFrame:
    """[-] Each rule's usage of every design in every load case, and the verdict there
    (:data:`~hisopt.studies.buildability.VERDICT_COLUMNS`): per design one row per load case
    and one more, ``load_case`` :data:`ALL_CASES`, with the verdict over them all
    (:func:`~hisopt.studies.buildability.verdicts`)."""
    parts = [verdicts([case]).assign(load_case=case.name) for case in cases]
    parts.append(verdicts(cases).assign(load_case=ALL_CASES))
    n = len(parts[-1])
    order = len(parts)
    frame = pd.concat([p.assign(design=np.arange(n), _order=k) for k, p in enumerate(parts)], ignore_index=True)
    frame = frame.sort_values(["design", "_order"], kind="stable").drop(columns="_order").reset_index(drop=True)
    frame = frame[list(usage_columns())]
    frame.attrs["units"] = dict.fromkeys(frame.columns, NO_UNIT)
    assert len(frame) == n * order
    return frame


def rule_cells(sheet: pd.DataFrame) -> pd.DataFrame:
    """A :func:`~hisopt.studies.buildability.rule_sheet` for reading: ``rule``, ``check``,
    ``load_case`` (where it binds), ``pressure`` (``abs``/``gauge``), ``value`` and ``limit``
    in engineering units (``–`` where the layout has no such part: nothing to check),
    ``margin`` in % and ``holds`` (``yes``, ``no``, or ``not evaluated``)."""
    rows = []
    for r in sheet.itertuples(index=False):
        show = RULE_DISPLAY.get(r.unit, Display(r.unit))
        evaluated, nothing = np.isfinite(r.usage), not np.isfinite(r.limit)
        rows.append(
            {
                "rule": r.rule,
                "check": r.check,
                "load_case": "–" if nothing and evaluated else r.load_case,
                "pressure": pressure_basis(r.rule) or "–",
                "value": "–" if nothing or not np.isfinite(r.value) else show(r.value),
                "limit": "–" if nothing else show(r.limit),
                "margin": f"{format_number(100.0 * r.margin)} %" if evaluated else "–",
                "holds": ("yes" if r.holds else "no") if evaluated else "not evaluated",
            }
        )
    return pd.DataFrame(rows, columns=["rule", "check", "load_case", "pressure", "value", "limit", "margin", "holds"])


def verdict_sentence(sheet: pd.DataFrame) -> str:
    """The verdict of one design's :func:`~hisopt.studies.buildability.rule_sheet` in words:
    buildable or not, the rules that fail, and the binding rule with its load case and margin."""
    if not np.isfinite(sheet["usage"].to_numpy(dtype=float)).all():
        return "Not buildable: the model cannot be evaluated in every load case (its valves have no fixed point, or it is unstable)."
    worst = sheet.loc[sheet["usage"].idxmax()]
    binding = f"the binding rule is {worst['rule']} ({worst['check']}) in {worst['load_case']}, margin {format_number(100.0 * worst['margin'])} %"
    failing = sheet.loc[~sheet["holds"], "rule"].tolist()
    if not failing:
        return f"Buildable: every rule holds in every load case; {binding}."
    return f"Not buildable: {len(failing)} of {len(sheet)} rules fail ({', '.join(failing)}); {binding}."


def design_verdicts(problems: list[DesignSpace], designs: list[Any]) -> pd.DataFrame:
    """[-] :data:`~hisopt.studies.buildability.VERDICT_COLUMNS` of one design per problem
    (``designs[i]`` a design of ``problems[i]``, or None: no design, an empty verdict)."""
    rows = []
    for problem, x in zip(problems, designs, strict=True):
        if x is None:
            rows.append({BUILDABLE: False, BINDING_RULE: "", BUILD_MARGIN: np.nan})
            continue
        verdict = buildability(problem, np.asarray(x, dtype=float)[None, :]).iloc[0]
        rows.append({k: verdict[k] for k in VERDICT_COLUMNS})
    frame = pd.DataFrame(rows, columns=list(VERDICT_COLUMNS))
    frame[BUILDABLE] = frame[BUILDABLE].astype(bool)
    frame.attrs["units"] = dict.fromkeys(VERDICT_COLUMNS, NO_UNIT)
    return frame
