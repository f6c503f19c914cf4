"""The evaluator's results as the docs/model.md §8.1 DataFrame: designs, quantities,
``feasible``, ``status`` and ``reason``."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.specification.validation import STATUS_FAILED, STATUS_OK, DesignCheck, check_designs
from hisopt.units import NO_UNIT, attach_units

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace


def failure_reason(problem: DesignSpace) -> str:
    """Why a design the rules admit has NaN results: the model is unstable or singular there,
    or, on a charged HIS, an accumulator holds no oil at rest (its static solve gives NaN,
    :func:`hisopt.coupled.operating_point.charged_static_pressure`)."""
    dry = ", or an accumulator holds no oil at rest" if problem.spec.his.charge is not None else ""
    valves = ", or the damper valves' RMS flows found no fixed point" if problem.network().solved_valves() else ""
    return f"the model is unstable or singular here{dry}{valves} (NaN results)"


def results_frame(problem: DesignSpace, designs: Any, quantities: dict[str, np.ndarray]) -> pd.DataFrame:
    """Designs and their quantities as a DataFrame.

    Columns: the variable names, the objective names, the constraint names (physical units,
    each quantity once; in a scenario problem also every ``"<quantity>@<scenario>"``), ``feasible`` (all constraints met, the model valid and the row
    ``ok``), ``status`` (``ok``, ``out_of_bounds``, ``invalid``, or ``failed`` for a model
    that is unstable or singular there) and ``reason`` (empty when ``ok``); their units in
    ``attrs["units"]``.
    """
    x = problem.design_matrix(designs)
    check: DesignCheck = check_designs(problem, x)
    columns = {name: x[:, j] for j, name in enumerate(problem.variable_names)} | {name: quantities[name] for name in problem.result_columns}
    df = pd.DataFrame(columns)  # at once: a problem of many load cases has hundreds of columns
    valid = np.asarray(quantities["valid"], dtype=bool)
    feasible = valid & check.ok
    for c in problem.spec.constraints:
        feasible &= quantities[c.name] <= c.limit
    df["feasible"] = feasible
    status, reason = check.status.copy(), check.reason.copy()
    failed = check.evaluable & ~valid
    status[failed & (status == STATUS_OK)] = STATUS_FAILED
    for i in np.flatnonzero(failed):
        reason[i] = "; ".join(r for r in (reason[i], failure_reason(problem)) if r)
    df["status"] = status.astype(str)
    df["reason"] = reason.astype(str)
    return attach_units(df, problem, {"reason": NO_UNIT})
