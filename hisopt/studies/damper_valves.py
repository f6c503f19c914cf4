"""A problem's physical damper valves as a reader sees them (docs/model.md §3.3, §17.4): each
valve's settings (orifice, discharge coefficient, cracking pressure, blow-off), and per load
case its RMS flow, its equivalent resistance, whether that lies in the linearisation's
validated range, and the damping ratio of the body's roll and bounce (heave) modes there.

The design sheet, ``hisopt evaluate --valves`` and the decision room read these; the numbers
are the evaluator's own (:func:`hisopt.evaluation.valve_states.valve_states` per load case).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.coupled.modal import modal_table
from hisopt.errors import ConfigError
from hisopt.evaluation.valve_states import OUTSIDE_VALIDATED_RANGE, VALIDATED_RESISTANCE, ValveStates, valve_states
from hisopt.hydraulics.network import resolve
from hisopt.units import NO_UNIT, format_quantity

if TYPE_CHECKING:
    from hisopt.specification.design_space import DesignSpace

ROAD_CASE = "road"
"""The load case of a problem without ``[[scenarios]]``: its ``[road]``."""
SETTINGS = (
    ("orifice_diameter", "m"),
    ("discharge_coefficient", NO_UNIT),
    ("cracking_pressure", "Pa"),
    ("blowoff_resistance", "Pa s m^-3"),
    ("resistance", "Pa s m^-3"),
)
"""The fields of :class:`hisopt.hydraulics.layout.DamperValve` a reader sets, with their SI
units (``resistance``: the laminar part in series)."""
SETTING_NAMES = {"resistance": "laminar_resistance"}
"""The ``[his]`` key of a field whose name there differs from the element's."""
DAMPED_MODES = ("roll", "bounce")
"""The body modes whose damping ratio the valves set: roll, and bounce (the body's heave)."""
ANY_FLOW = 1e-4
"""[m^3/s] The RMS flow a model is built at only to read its valves' settings."""
INSIDE = "inside"
OUTSIDE = "outside"
NO_FIXED_POINT = "no fixed point"
NOT_EVALUATED = "not evaluated"
"""The values of a ``validated_range`` column: the last two for a design whose valves' RMS
flows have no fixed point in that load case, and for one breaking a parameter's rule (no
resistance to judge)."""


VALVE_TABLE_COLUMNS = ("design", "load_case", "valve", "flow_rms", "resistance", "validated_range", "converged")
"""The columns of :func:`valve_table`, in order."""


@dataclass(frozen=True)
class LoadCaseValves:
    """The damper valves of designs ``x`` [SI] ``(n, n_var)`` in one load case: ``name`` (a
    scenario's, or :data:`ROAD_CASE`), its single-case problem ``space``, the valves'
    ``states`` and which rows were ``evaluated`` (``(n,)``; not those breaking a parameter's
    rule, as ``Problem.evaluate`` does not evaluate them)."""

    name: str
    space: Any
    x: np.ndarray
    states: ValveStates
    evaluated: np.ndarray

    def model(self, design: int) -> Any:
        """The coupled model of design row ``design`` with its valves at this case's fixed point."""
        return self.space.model(self.x[[design]], inputs={k: v[[design]] for k, v in self.states.inputs.items()})


def has_damper_valves(problem: DesignSpace) -> bool:
    """[-] Whether ``problem``'s layout holds a physical damper valve."""
    return bool(problem.network().damper_valves())


def check_damper_valves(problem: DesignSpace, option: str) -> None:
    """Refuse ``option`` on a problem without damper valves.

    Raises
    ------
    ConfigError
        ``problem`` has no damper valve (naming ``option``).
    """
    if not has_damper_valves(problem):
        raise ConfigError(
            f"problem {problem.name!r} has no damper valves; expected a problem with [his] orifice_diameter or a damper_valve layout element",
            key=option,
        )


def load_cases(problem: DesignSpace) -> list[tuple[str, Any]]:
    """``(name, single-case problem)`` of each load case: every scenario, or the problem's road."""
    if problem.scenario_names:
        return [(name, problem.scenario_space(name)) for name in problem.scenario_names]
    return [(ROAD_CASE, problem)]


def load_case_valves(problem: DesignSpace, designs: Any) -> list[LoadCaseValves]:
    """Each load case's :class:`~hisopt.evaluation.valve_states.ValveStates` of ``designs``
    (any form :meth:`~hisopt.specification.design_space.DesignSpace.design_matrix` takes)."""
    x = problem.design_matrix(designs)
    return [LoadCaseValves(name, space, x, *_states(space, x)) for name, space in load_cases(problem)]


def _states(space: Any, x: np.ndarray) -> tuple[ValveStates, np.ndarray]:
    """:func:`~hisopt.evaluation.valve_states.valve_states` of the rows of ``x`` that can be
    evaluated (a row breaking a parameter's rule gets NaN, not converged); a batch whose model
    cannot be built at all (one design the model refuses) is solved design by design, so that
    one bad row does not blank the others. Also which rows were evaluated."""
    from hisopt.specification.validation import STATUS_INVALID, check_designs

    rows = np.flatnonzero(check_designs(space, x).status != STATUS_INVALID)
    found = valve_states(space, x[rows])
    if len(rows) > 1 and not found.converged.any():
        each = [valve_states(space, x[[i]]) for i in rows]
        found = ValveStates(
            found.labels,
            np.vstack([e.flow_rms for e in each]),
            np.vstack([e.resistance for e in each]),
            np.concatenate([e.converged for e in each]),
            {k: np.concatenate([e.inputs.get(k, np.full(1, np.nan)) for e in each]) for k in found.inputs},
        )
    n, m = len(x), len(found.labels)
    flow, resistance, converged = np.full((n, m), np.nan), np.full((n, m), np.nan), np.zeros(n, dtype=bool)
    flow[rows], resistance[rows], converged[rows] = found.flow_rms, found.resistance, found.converged
    inputs = {k: np.full(n, np.nan) for k in found.inputs}
    for k, v in found.inputs.items():
        inputs[k][rows] = v
    evaluated = np.zeros(n, dtype=bool)
    evaluated[rows] = True
    return ValveStates(found.labels, flow, resistance, converged, inputs), evaluated


def valve_settings(case: LoadCaseValves, design: int = 0) -> pd.DataFrame:
    """[SI] One row per damper valve of design row ``design``: ``valve`` and each of
    :data:`SETTINGS` (``[his]`` names: ``laminar_resistance`` for the laminar part; NaN where
    the valve has none), with ``key`` the parameters whose names differ from those
    (``orifice_diameter_rear, cracking_pressure_rear`` for a rear valve of its own)."""
    states = case.states
    # the settings do not depend on the flows: a design without a fixed point is built at any flow
    inputs = {k: np.where(np.isfinite(v[[design]]), v[[design]], ANY_FLOW) for k, v in states.inputs.items()}
    his = case.space.model(case.x[[design]], inputs=inputs).his
    assert his is not None  # a model with HIS
    rows: list[dict[str, Any]] = []
    for label, (_, valve, _) in zip(states.labels, his.network.damper_valves(), strict=True):
        row: dict[str, Any] = {"valve": label}
        keys = []
        for field_name, _ in SETTINGS:
            ref = getattr(valve, field_name)
            name = SETTING_NAMES.get(field_name, field_name)
            row[name] = np.nan if ref is None else float(np.ravel(resolve(ref, his.params))[0])
            if isinstance(ref, str) and ref != name:
                keys.append(ref)
        row["key"] = ", ".join(keys)
        rows.append(row)
    frame = pd.DataFrame(rows)
    frame.attrs["units"] = {"valve": NO_UNIT, "key": NO_UNIT} | {SETTING_NAMES.get(f, f): u for f, u in SETTINGS}
    return frame


def valve_table(cases: list[LoadCaseValves]) -> pd.DataFrame:
    """[SI] One row per design, load case and valve: ``design`` (row of the designs, from 0),
    ``load_case``, ``valve``, ``flow_rms`` [m^3/s], ``resistance`` [Pa s m^-3] (equivalent),
    ``validated_range`` (:data:`INSIDE` or :data:`OUTSIDE`, see
    :data:`~hisopt.evaluation.valve_states.VALIDATED_RESISTANCE`; :data:`NO_FIXED_POINT`,
    :data:`NOT_EVALUATED`)
    and ``converged``."""
    frames = []
    for case in cases:
        s = case.states
        n, m = s.resistance.shape
        outside = s.outside()
        judged = np.where(outside, OUTSIDE, INSIDE)
        missing = np.where(case.evaluated, NO_FIXED_POINT, NOT_EVALUATED)[:, None]
        frames.append(
            pd.DataFrame(
                {
                    "design": np.repeat(np.arange(n), m),
                    "load_case": case.name,
                    "valve": np.tile(np.asarray(s.labels, dtype=object), n),
                    "flow_rms": s.flow_rms.ravel(),
                    "resistance": s.resistance.ravel(),
                    "validated_range": np.where(np.isfinite(s.resistance), judged, missing).ravel(),
                    "converged": np.repeat(s.converged, m),
                }
            )
        )
    table = pd.concat(frames, ignore_index=True).sort_values(["design"], kind="stable").reset_index(drop=True)[list(VALVE_TABLE_COLUMNS)]
    units = {"design": NO_UNIT, "load_case": NO_UNIT, "valve": NO_UNIT, "flow_rms": "m^3/s", "resistance": "Pa s m^-3"}
    table.attrs["units"] = units | {"validated_range": NO_UNIT, "converged": NO_UNIT}
    return table


def range_note() -> str:
    """What :data:`OUTSIDE` means, for a reader: the threshold and the time-domain gaps."""
    limit = format_quantity(VALIDATED_RESISTANCE, "Pa s m^-3")
    return f"{OUTSIDE}: an equivalent resistance over {limit} is {OUTSIDE_VALIDATED_RANGE}; its quantities are the linearisation's, less sure than inside."


def designs_outside(cases: list[LoadCaseValves]) -> np.ndarray:
    """[-] Whether each design has a valve outside the validated range in some load case, ``(n,)``."""
    return np.any([case.states.outside().any(axis=1) for case in cases], axis=0)


def outside_summary(cases: list[LoadCaseValves], source: str) -> str | None:
    """One line counting the designs of ``source`` with a valve outside the validated range or
    without a fixed point in some load case (None if there are none)."""
    n = len(cases[0].x) if cases else 0
    outside = int(designs_outside(cases).sum()) if n else 0
    failed = int(np.any([case.evaluated & ~case.states.converged for case in cases], axis=0).sum()) if n else 0
    said = [f"{outside} of {n} designs have a damper valve {OUTSIDE_VALIDATED_RANGE}"] if outside else []
    said += [f"{failed} of {n} designs have no fixed point of their valves' RMS flows"] if failed else []
    return f"{source}: {'; '.join(said)}; see --valves" if said else None


def mode_damping(cases: list[LoadCaseValves], design: int = 0) -> pd.DataFrame:
    """One row per load case of design row ``design``: ``load_case`` and, for each of
    :data:`DAMPED_MODES`, ``<mode>_frequency_hz`` [Hz] and ``<mode>_damping_ratio`` [-] of
    the model with its valves at that case's fixed point (NaN where the mode is not found or
    the fixed point failed)."""
    rows = []
    for case in cases:
        row: dict[str, Any] = {"load_case": case.name}
        for mode in DAMPED_MODES:
            row[f"{mode}_frequency_hz"] = row[f"{mode}_damping_ratio"] = np.nan
        if case.states.converged[design]:
            modes = modal_table(case.model(design))
            for mode in DAMPED_MODES:
                found = modes[modes["mode"] == mode]
                if len(found):
                    row[f"{mode}_frequency_hz"] = float(found["frequency_hz"].iloc[0])
                    row[f"{mode}_damping_ratio"] = float(found["damping_ratio"].iloc[0])
        rows.append(row)
    frame = pd.DataFrame(rows)
    frame.attrs["units"] = {"load_case": NO_UNIT} | {f"{m}_{q}": u for m in DAMPED_MODES for q, u in (("frequency_hz", "Hz"), ("damping_ratio", NO_UNIT))}
    return frame
