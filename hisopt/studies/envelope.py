"""The operating envelope of one design: every temperature and load of a problem (docs/model.md §16.7).

A design tuned at one operating point must work at all of them: from a winter morning to a
hot laden motorway run. :func:`envelope_table` takes every temperature and every payload the
problem names (the problem's own and each load case's; the reference temperature if none)
and, for each pair, the static state of every circuit (absolute pressure, the gas's share of
each accumulator, the pressure over the precharge at that temperature) and the ride and
handling it gives on the problem's ``[road]``: one road for every row, so the rows compare.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hisopt.coupled.operating_point import static_displacement
from hisopt.coupled.payload import Payload
from hisopt.hydraulics import laws
from hisopt.hydraulics.layout import Accumulator
from hisopt.hydraulics.network import resolve
from hisopt.hydraulics.roll_plane import reference_temperature
from hisopt.problem import Problem
from hisopt.specification.design_space import DesignSpace
from hisopt.units import attach_units

QUANTITIES = ("sigma_aw", "roll_gradient")
"""The ride and handling quantities of each row."""

CHARGED_QUANTITIES = ("accumulator_swing",)
"""And of a charged HIS's rows: the accumulators' dynamic margin on the road (docs/model.md §16.9)."""


def row_quantities(problem: DesignSpace) -> tuple[str, ...]:
    """The quantities of each row: :data:`QUANTITIES`, and :data:`CHARGED_QUANTITIES` for a
    charged HIS (the idealisation holds no oil to swing)."""
    return QUANTITIES + (CHARGED_QUANTITIES if problem.spec.his.charge is not None else ())


CELSIUS_OFFSET = 273.15
"""[K] 0 degC."""


def envelope_cases(problem: DesignSpace) -> list[tuple[float, Payload | None]]:
    """``(temperature [K], payload)`` of every row: each load case's temperature (the
    problem's, else the reference temperature, for a case that names none) with each payload
    (none, then every payload of a load case or ``[payload]``), coldest first."""
    spec = problem.spec
    default = spec.temperature if spec.temperature is not None else reference_temperature(spec.his)
    temperatures = {sc.temperature if sc.temperature is not None else default for sc in spec.scenarios} or {default}
    payloads: list[Payload | None] = [None]
    for p in [spec.payload, *(sc.payload for sc in spec.scenarios)]:
        if p is not None and p.active and p not in payloads:
            payloads.append(p)
    return [(t, p) for t in sorted(temperatures) for p in payloads]


def case_space(problem: Problem, temperature: float, payload: Payload | None) -> Problem:
    """The single-case problem of one row: ``[road]``, the temperature and payload, the
    :func:`row_quantities` as its objectives."""
    update = {"temperature": temperature, "payload": payload, "scenarios": [], "objectives": list(row_quantities(problem)), "constraints": []}
    spec = problem.spec.model_copy(update=update)
    return type(problem)(spec, problem.path)


def static_state(space: DesignSpace, x: np.ndarray) -> dict[str, np.ndarray]:
    """[m], [Pa], [-] The body's static rise at its CG from the design position ``ride_height``
    (:func:`hisopt.coupled.operating_point.static_displacement`) and, per circuit of the
    designs ``x`` (n, n_var), its absolute static pressure
    ``p_static_<circuit>``, its accumulators' least gas share ``gas_fraction_<circuit>`` and
    their highest static pressure over the precharge at the temperature
    ``pressure_ratio_<circuit>`` (the gas at ``V / V0`` and ``p`` of its linearisation;
    NaN where the model refuses the design)."""
    his = space.model(x).his
    assert his is not None  # a model with HIS
    params, net = his.params, his.network
    tau = params.get("gas_temperature_ratio", 1.0)
    heave = static_displacement(space.spec.vehicle, space.spec.payload, his)[..., 0]
    out: dict[str, np.ndarray] = {"ride_height": np.broadcast_to(heave, (len(x),))}
    for k, (c, e) in enumerate(net.elements):
        if not isinstance(e, Accumulator):
            continue
        name = net.layout.circuits[c].name
        v, p_abs, _ = his.values.gas[k]
        v0 = resolve(e.volume, params)
        precharge = laws.gas_pressure_at_temperature(laws.absolute_pressure(resolve(e.precharge, params)), tau)
        columns = {
            f"p_static_{name}": (np.asarray(p_abs, dtype=float), np.maximum),
            f"gas_fraction_{name}": (np.asarray(v / v0, dtype=float), np.minimum),
            f"pressure_ratio_{name}": (np.asarray(p_abs / precharge, dtype=float), np.maximum),
        }
        for column, (value, pick) in columns.items():
            value = np.broadcast_to(value, (len(x),))
            out[column] = value if column not in out else pick(out[column], value)
    return out


def envelope_table(problem: Problem, design: Any = None) -> pd.DataFrame:
    """One row per temperature and load (:func:`envelope_cases`) of one design (default: the
    baseline): ``temperature`` [K], ``payload`` [kg], the :func:`static_state` columns and
    the :func:`row_quantities`, with their units in ``attrs["units"]``; ``model`` names the
    charge model (``ideal``: the paper's idealisation, or ``charged``)."""
    x = problem.design_matrix(problem.baseline if design is None else design)[:1]
    rows = []
    for temperature, payload in envelope_cases(problem):
        space = case_space(problem, temperature, payload)
        row: dict[str, Any] = {"temperature": temperature, "payload": 0.0 if payload is None else payload.mass}
        row |= {k: float(v[0]) for k, v in static_state(space, x).items()}
        values = space.evaluator()(x)
        row |= {q: float(values[q][0]) for q in row_quantities(problem)}
        rows.append(row)
    frame = pd.DataFrame(rows)
    frame.insert(0, "model", "charged" if problem.spec.his.charge is not None else "ideal")
    units = {"temperature": "K", "payload": "kg", "model": "-", "ride_height": "m"}
    for column in frame.columns:
        if column.startswith("p_static_"):
            units[column] = "Pa"
        elif column.startswith(("gas_fraction_", "pressure_ratio_")):
            units[column] = "-"
    return attach_units(frame, problem, units)


def shown_envelope(table: pd.DataFrame) -> pd.DataFrame:
    """The table for reading: temperatures in degC (a point on its scale, which reads back),
    without the ``model`` column (the title says it)."""
    shown = table.drop(columns="model")
    shown["temperature"] = [f"{t - CELSIUS_OFFSET:.4g}" for t in table["temperature"]]
    shown.attrs = {"units": dict(table.attrs.get("units", {})) | {"temperature": "degC"}}
    return shown


def knee_design(problem: DesignSpace, run_dir: Path) -> np.ndarray:
    """[SI] The knee design of a run directory's front (:func:`hisopt.optim.decision.front_design`
    of ``front.csv``), as a design row of ``problem``."""
    from hisopt.optim.decision import front_design
    from hisopt.optim.rundir import FRONT_CSV

    return front_design(problem, Path(run_dir) / FRONT_CSV)[1][None, :]
