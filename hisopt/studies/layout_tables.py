"""The tables of a layout study from its runs (:mod:`hisopt.studies.layout_study`).

Pure assembly plus the refinements of the equal-handling comparison: the runs' fronts and
feasible designs in, ``layouts.csv``, ``runs.csv``, ``fronts.csv``, ``handling_curve.csv``
and ``attainment.csv`` out, all deterministic in the runs' order (layout, then seed).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.metrics import METRICS
from hisopt.studies.layout_cases import REFERENCE_LAYOUT, LayoutCase
from hisopt.studies.layout_metrics import COMFORT, Normalisation, attainment, best_at_limit, normalised_hypervolume, plane_front
from hisopt.units import NO_UNIT, column_unit, format_quantity, variable_units, with_units

if TYPE_CHECKING:
    from hisopt.evaluation.parallel import Backend
    from hisopt.problem import Problem


NO_REFINEMENT = "none"
"""[-] The refinement method that refines nothing: each layout's equal-handling comfort is its
best sampled design at the limit, and its curve the sampled staircase."""


def _refine_task(task: tuple[str, np.ndarray, float, str], problems: dict[str, Problem], handling: str) -> dict[str, Any]:
    """Best comfort under ``handling <= limit`` from a start design, by the NLP (its method:
    IPOPT on CasADi's virtual machine, at most 8 trust-region rounds, or the batched SLP)."""
    from hisopt.optim.gradient.refine import RefineSettings, refine_constrained

    name, x0, limit, method = task
    settings = RefineSettings(rounds=8) if method == "ipopt" else None
    point = refine_constrained(problems[name], x0, COMFORT, {handling: limit}, settings, method=method)
    return {"accepted": point.accepted, "x": point.x, COMFORT: point.quantities[COMFORT], handling: point.quantities[handling]}


def _pool(runs: list[dict[str, Any]], name: str) -> pd.DataFrame:
    """Every feasible design of a layout's runs, in seed order, with a ``seed`` column."""
    parts = [r["designs"].assign(seed=r["seed"]) for r in runs if r["layout"] == name]
    return pd.concat(parts, ignore_index=True)


def _curve_starts(pool: pd.DataFrame, handling: str, count: int) -> list[int]:
    """[-] Rows of ``pool`` on its staircase at ``count`` evenly spaced steps (ends included)."""
    steps = plane_front(pool[COMFORT].to_numpy(), pool[handling].to_numpy())
    if len(steps) == 0:
        return []
    picks = np.unique(np.round(np.linspace(0, len(steps) - 1, min(count, len(steps)))).astype(int))
    return [int(steps[i]) for i in picks]


def assemble(
    cases: list[LayoutCase],
    runs: list[dict[str, Any]],
    norm: Normalisation,
    handling: str,
    limit: float,
    backend: Backend,
    curve_refined: int = 4,
    method: str = "ipopt",
) -> dict[str, pd.DataFrame]:
    """``table``, ``runs``, ``fronts``, ``curve`` and ``attainment`` of a study (module docstring).

    Parameters
    ----------
    cases : list[LayoutCase]
        the layouts, roll-plane first
    runs : list[dict[str, Any]]
        per (layout, seed) task, in that order: ``layout``, ``seed``, ``front``
        (variables and objectives), ``designs`` (every feasible design: ``evaluation``,
        variables, ``sigma_aw``, the handling quantity), ``evaluations``
    norm : Normalisation
        the shared normalisation
    handling : str
        [-] the handling quantity; limit : [its unit] the equal-handling limit
    backend : Backend
        where the refinements run
    curve_refined : int, optional
        [-] refined points per layout on the trade-off curve
    method : str, optional
        [-] the solver of the equal-handling refinements, ``"ipopt"`` (on CasADi's virtual
        machine) or ``"slp"`` (:func:`hisopt.optim.gradient.refine.refine_constrained`); the
        trade-off curve's points are refined by the SLP (docs/model.md §15.4);
        :data:`NO_REFINEMENT` refines nothing
    """
    problems = {c.name: c.problem for c in cases}
    objectives = list(norm.objectives)
    h_unit = METRICS[handling].unit if handling in METRICS else column_unit(handling)
    pools = {c.name: _pool(runs, c.name) for c in cases}

    # ---- refinements: from each seed's best design at the limit, then points along each curve ------
    tasks: list[tuple[str, np.ndarray, float, str]] = []
    best_row: dict[str, int | None] = {}
    # the NLP's CasADi model holds each valve at one resistance: damper valves whose RMS flows
    # are solved per design (docs/model.md §3.3) keep their layout's sampled designs unrefined
    refinable = {c.name: method != NO_REFINEMENT and not c.problem.network().solved_valves() for c in cases}
    for c in cases:
        pool, names = pools[c.name], list(c.problem.variable_names)
        best_row[c.name] = best_at_limit(pool[COMFORT].to_numpy(), pool[handling].to_numpy(), limit) if len(pool) else None
        for _, part in pool.groupby("seed", sort=True) if refinable[c.name] else ():  # several starts: the NLP finds local optima
            i = best_at_limit(part[COMFORT].to_numpy(), part[handling].to_numpy(), limit)
            if i is not None:
                tasks.append((c.name, part.iloc[i][names].to_numpy(dtype=float), limit, method))
    n_equal = len(tasks)
    for c in cases:
        pool, names = pools[c.name], list(c.problem.variable_names)
        for i in _curve_starts(pool, handling, curve_refined) if len(pool) and refinable[c.name] else []:
            tasks.append((c.name, pool.loc[i, names].to_numpy(dtype=float), float(pool.loc[i, handling]), "slp"))  # the curve: cheap
    refined = backend.map(_refine_task, tasks, problems, handling)

    # ---- per run: hypervolume in the shared normalisation ------------------------------------------
    run_rows, front_parts = [], []
    for r in runs:
        f = r["front"][objectives].to_numpy(dtype=float)
        run_rows.append(
            {
                "layout": r["layout"],
                "seed": r["seed"],
                "hypervolume": normalised_hypervolume(f, norm),
                "front_size": len(f),
                "evaluations": r["evaluations"],
                "feasible_designs": len(r["designs"]),
            }
        )
        part = r["front"][objectives].assign(layout=r["layout"], seed=r["seed"])
        z = norm.objective_space(f) if len(f) else np.zeros((0, len(objectives)))
        for j, name in enumerate(objectives):
            part[f"{name}_norm"] = z[:, j]
        front_parts.append(part)
    run_frame = pd.DataFrame(run_rows)
    fronts = pd.concat(front_parts, ignore_index=True)
    fronts = fronts[["layout", "seed", *objectives, *[f"{n}_norm" for n in objectives]]]

    # ---- curve, attainment and the table, per layout -----------------------------------------------
    curve_parts, attain_rows, rows = [], [], []
    designs: dict[str, np.ndarray | None] = {}
    equal: dict[str, list[dict[str, Any]]] = {}
    for i in range(n_equal):
        equal.setdefault(tasks[i][0], []).append(refined[i])
    along = [(tasks[i][0], refined[i]) for i in range(n_equal, len(tasks))]
    for c in cases:
        pool = pools[c.name]
        steps = pool.iloc[plane_front(pool[COMFORT].to_numpy(), pool[handling].to_numpy())]
        sampled = pd.DataFrame(
            {"layout": c.name, "source": "sampled", "seed": steps["seed"].to_numpy(), handling: steps[handling].to_numpy(), COMFORT: steps[COMFORT].to_numpy()}
        )
        better = [res for name, res in along if name == c.name and res["accepted"]]
        better += [res for res in equal.get(c.name, []) if res["accepted"]]
        extra = pd.DataFrame(
            {"layout": c.name, "source": "refined", "seed": -1, handling: [r[handling] for r in better], COMFORT: [r[COMFORT] for r in better]}
        )
        both = pd.concat([sampled, extra], ignore_index=True) if len(extra) else sampled
        keep = plane_front(both[COMFORT].to_numpy(dtype=float), both[handling].to_numpy(dtype=float))
        curve_parts.append(both.iloc[keep])

        sets = [
            norm.plane(pool.loc[pool["seed"] == r["seed"], COMFORT].to_numpy(), pool.loc[pool["seed"] == r["seed"], handling].to_numpy())
            for r in runs
            if r["layout"] == c.name
        ]
        att = attainment(sets)
        for kind, pts, pct in (
            ("eaf", att.surfaces[:, :2], att.surfaces[:, 2]),
            ("vorobev", att.vorobev_expectation, np.full(len(att.vorobev_expectation), att.vorobev_threshold_pct)),
        ):
            inside = np.all(np.asarray(pts).reshape(-1, 2) < 1.0, axis=1)  # not the placeholder corner of a seed that attains nothing
            pts, pct = np.asarray(pts).reshape(-1, 2)[inside], pct[inside]
            phys = norm.from_plane(pts) if len(pts) else np.zeros((0, 2))
            attain_rows.append(pd.DataFrame({"layout": c.name, "kind": kind, "percentile_pct": pct, COMFORT: phys[:, 0], handling: phys[:, 1]}))

        hv = run_frame.loc[run_frame["layout"] == c.name, "hypervolume"].to_numpy()
        merged = fronts.loc[fronts["layout"] == c.name, objectives].to_numpy(dtype=float)
        row: dict[str, Any] = {
            "layout": c.name,
            "source": c.source,
            "variables": " ".join(c.problem.variable_names),
            "hv_mean": hv.mean(),
            "hv_std": hv.std(ddof=1) if len(hv) > 1 else np.nan,
            "hv_min": hv.min(),
            "hv_max": hv.max(),
            "hv_merged": normalised_hypervolume(merged, norm),
            "vorobev_threshold_pct": att.vorobev_threshold_pct,
            "vorobev_deviation": att.vorobev_deviation,
            "handling": handling,
            "handling_limit": limit,
        }
        choice = _equal_handling(c, pool, best_row[c.name], equal.get(c.name, []), handling)
        designs[c.name] = choice.pop("x")
        row |= choice | _limit_status(pool, handling, limit, h_unit)
        rows.append(row)
    table = pd.DataFrame(rows)
    reference = table.loc[table["layout"] == REFERENCE_LAYOUT, "sigma_aw_at_limit"].to_numpy()
    table.insert(table.columns.get_loc("refined") + 1, "gain_vs_roll_plane_pct", 100.0 * (1.0 - table["sigma_aw_at_limit"] / reference[0]))
    table = _with_verdicts(_with_stiffness_and_designs(table, cases, designs), cases, designs)

    curve = pd.concat(curve_parts, ignore_index=True)
    attain = pd.concat(attain_rows, ignore_index=True)
    quantity_units = {COMFORT: METRICS[COMFORT].unit, handling: h_unit} | {n: METRICS[n].unit for n in objectives if n in METRICS}
    labels = {"layout": NO_UNIT, "source": NO_UNIT, "seed": NO_UNIT, "kind": NO_UNIT, "variables": NO_UNIT, "handling": NO_UNIT}
    units = labels | quantity_units | {f"{n}_norm": NO_UNIT for n in objectives}
    units |= {"hypervolume": NO_UNIT, "front_size": NO_UNIT, "evaluations": NO_UNIT, "feasible_designs": NO_UNIT}
    units |= {
        "percentile_pct": "%",
        "vorobev_threshold_pct": "%",
        "vorobev_deviation": NO_UNIT,
        "handling_limit": h_unit,
        "sigma_aw_at_limit": METRICS[COMFORT].unit,
        "handling_at_best": h_unit,
        "refined": NO_UNIT,
        "handling_least": h_unit,
        "at_limit": NO_UNIT,
        "gain_vs_roll_plane_pct": "%",
    } | {f"hv_{k}": NO_UNIT for k in ("mean", "std", "min", "max", "merged")}
    units |= table.attrs.get("units", {})
    return {
        name: with_units(frame, units) for name, frame in (("table", table), ("runs", run_frame), ("fronts", fronts), ("curve", curve), ("attainment", attain))
    }


def _equal_handling(case: LayoutCase, pool: pd.DataFrame, best: int | None, refined: list[dict[str, Any]], handling: str) -> dict[str, Any]:
    """``sigma_aw_at_limit``, ``handling_at_best``, ``refined`` and the design ``x`` of one layout:
    the best of the sampled designs and the accepted refinements (NaN, None: none meets the limit)."""
    if best is None:
        return {"sigma_aw_at_limit": np.nan, "handling_at_best": np.nan, "refined": False, "x": None}
    out = {
        "sigma_aw_at_limit": float(pool.loc[best, COMFORT]),
        "handling_at_best": float(pool.loc[best, handling]),
        "refined": False,
        "x": pool.loc[best, list(case.problem.variable_names)].to_numpy(dtype=float),
    }
    for r in refined:  # in seed order; the first of equals stays
        if r["accepted"] and r[COMFORT] < out["sigma_aw_at_limit"]:
            out = {"sigma_aw_at_limit": r[COMFORT], "handling_at_best": r[handling], "refined": True, "x": r["x"]}
    return out


def _limit_status(pool: pd.DataFrame, handling: str, limit: float, unit: str) -> dict[str, Any]:
    """``handling_least`` (the least handling of any feasible design of the layout's runs, NaN
    with none) and ``at_limit``: ``met``, or in words why the layout has no value at the limit."""
    least = float(pool[handling].min()) if len(pool) else np.nan
    if not len(pool):
        status = "no feasible design"
    elif least <= limit:
        status = "met"
    else:
        status = f"none of {len(pool)} feasible designs meets {handling} <= {format_quantity(limit, unit)} (least {format_quantity(least, unit)})"
    return {"handling_least": least, "at_limit": status}


def _with_verdicts(table: pd.DataFrame, cases: list[LayoutCase], designs: dict[str, np.ndarray | None]) -> pd.DataFrame:
    """``buildable``, ``binding_rule`` and ``build_margin`` of each layout's design at the limit
    (the ``best_<variable>`` design), after ``at_limit``: every buildability rule, whether or
    not the problem constrains it (empty, not buildable, without a design)."""
    from hisopt.studies.build_views import design_verdicts

    verdicts = design_verdicts([c.problem for c in cases], [designs[c.name] for c in cases])
    at = table.columns.get_loc("at_limit") + 1
    units = dict(table.attrs.get("units", {})) | verdicts.attrs["units"]
    for k, name in enumerate(verdicts.columns):
        table.insert(at + k, name, verdicts[name].to_numpy())
    table.attrs["units"] = units
    return table


def _with_stiffness_and_designs(table: pd.DataFrame, cases: list[LayoutCase], designs: dict[str, np.ndarray | None]) -> pd.DataFrame:
    """The mode stiffness columns (``hisopt layouts``) and ``best_<variable>`` columns."""
    from hisopt.studies.screening import screened_properties

    units: dict[str, str] = {}
    stiffness, rows = [], []
    for c in cases:
        stiffness.append(screened_properties(c.problem.spec.his, c.problem))
        names = list(c.problem.variable_names)
        units |= {f"best_{n}": u for n, u in variable_units(c.problem).items()}
        x = designs[c.name]
        rows.append({} if x is None else {f"best_{n}": float(v) for n, v in zip(names, x, strict=True)})
    extra = pd.DataFrame(stiffness)
    units |= {k: "N/m" for k in extra.columns if k.startswith("k_")} | {k: "N s/m" for k in extra.columns if k.startswith("c_")}
    units["stiffness_coupling"] = NO_UNIT
    if extra["damper_valves"].astype(bool).any():
        units["damper_valves"] = NO_UNIT
    else:
        extra = extra.drop(columns="damper_valves")
    columns = list(dict.fromkeys(f"best_{n}" for c in cases for n in c.problem.variable_names))
    out = pd.concat([table, extra, pd.DataFrame(rows, columns=columns)], axis=1)
    out.attrs["units"] = units
    return out
