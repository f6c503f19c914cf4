"""Screening HIS layouts: the stiffness and damping each adds to the four stroke patterns.

``hisopt layouts [PROBLEM]`` and :func:`mode_stiffness` list the catalogue (and a problem's
custom layout) with, at the problem's baseline values, what each layout adds to the car's
suspension in the four stroke patterns (docs/model.md §12.4)::

    bounce  u = ( 1,  1,  1,  1)        pitch  u = ( 1,  1, -1, -1)
    roll    u = ( 1, -1,  1, -1)        warp   u = ( 1, -1, -1,  1)

(strokes of FL, FR, RL, RR, extension positive; roll: the left side extends, pitch: the
front extends). "Per unit modal stroke" means per metre of the pattern's amplitude ``x`` in
``delta = x u``: each strut moves ``x``. The static stiffness of a pattern is
``u^T K_his u`` [N/m] (``K_his = lim_{s->0} D(s)``; the work-conjugate force per metre of
``x``), its low-frequency damping ``u^T C_lf u`` [N s/m] with
``C_lf = lim_{s->0} (D(s) - K_his) / s`` (:func:`hisopt.hydraulics.network.low_frequency_damping`).
``stiffness_coupling`` is the largest ``|U^T K U|_ij / sqrt(|U^T K U|_ii |U^T K U|_jj)`` between two
patterns (0: the patterns stay uncoupled statically).

Given a problem, each layout is screened on the model the evaluator builds for the problem's
baseline design in the problem's own load case (:func:`operating_system`): a charged HIS
(``[his.charge]``) linearised at its static pressures, at the problem's temperature and
payload, so ``k_roll`` is the roll stiffness of :meth:`hisopt.coupled.model.CoupledModel.stiffness`.

Physical damper valves (``[his] orifice_diameter``, or ``damper_valve`` elements) damp as hard
as the road drives them: each layout is screened with its valves held at their equivalent
resistance at the problem's baseline design on the problem's road
(:func:`baseline_valve_resistance`), and ``damper_valves`` names them (:func:`damper_valve_note`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from hisopt.arguments import problem_argument
from hisopt.errors import ModelError
from hisopt.hydraulics.catalogue import CUSTOM, catalogue, his_layout, his_parameter_values
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.layout import Circuit, DamperValve, Layout, Valve
from hisopt.hydraulics.network import compile_network
from hisopt.units import NO_UNIT, format_quantity, with_units

if TYPE_CHECKING:
    from hisopt.hydraulics.roll_plane import RollPlaneHIS
    from hisopt.specification.design_space import DesignSpace

STROKE_PATTERNS: dict[str, tuple[float, float, float, float]] = {
    "bounce": (1.0, 1.0, 1.0, 1.0),
    "roll": (1.0, -1.0, 1.0, -1.0),
    "pitch": (1.0, 1.0, -1.0, -1.0),
    "warp": (1.0, -1.0, -1.0, 1.0),
}
"""Unit stroke patterns (FL, FR, RL, RR; extension positive), see the module docstring."""

RESISTANCE_UNIT = "Pa s m^-3"


def pattern_matrix() -> np.ndarray:
    """[-] ``U``: the stroke patterns as rows, shape ``(4, 4)`` (bounce, roll, pitch, warp)."""
    return np.array(list(STROKE_PATTERNS.values()))


def layout_his(his: RollPlaneHIS, name: str) -> RollPlaneHIS:
    """``his`` with catalogue layout ``name`` (the problem's own table for its own layout);
    ``[his.parameters]`` entries the other layout does not read are dropped."""
    if name == his.layout:
        return his
    defaults = catalogue()[name].parameters
    params = {k: v for k, v in his.parameters.items() if k in defaults}
    return his.model_copy(update={"layout": name, "circuits": None, "parameters": params})


def layout_system(his: RollPlaneHIS, space: DesignSpace | None = None) -> HydraulicSystem:
    """The HIS of a ``[his]`` table at its own values (lumped pipes), one design.

    Its physical damper valves are linear valves at their equivalent resistance for the
    baseline design of ``space`` (a problem with this ``[his]``) on that problem's road
    (:func:`baseline_valve_resistance`): the screening's damping is the one the road sees.

    Raises
    ------
    ModelError
        The layout has damper valves whose flows are solved and no ``space`` is given.
    """
    return screened_system(his, space)[0]


def screened_system(his: RollPlaneHIS, space: DesignSpace | None = None) -> tuple[HydraulicSystem, np.ndarray]:
    """:func:`layout_system` and its damper valves' equivalent resistances [Pa s m^-3] in
    element order (empty without damper valves; NaN when their flows have no fixed point at
    the baseline: the system then holds them at 1 Pa s m^-3, which no static value reads).

    Given ``space`` (a problem with this ``[his]``), the system is the one its evaluator
    builds for its baseline design in the problem's own load case (:func:`operating_system`:
    a charged HIS at its static pressures, a payload's static rise, the problem's
    temperature); without it, ``his`` at its values with the accumulators at their precharge.
    """
    layout = his_layout(his)
    system = operating_system(space) if space is not None else HydraulicSystem(compile_network(layout, "lumped"), his_parameter_values(his))
    resistance = np.zeros(0)
    if compile_network(layout, "lumped").damper_valves():
        if space is None:
            raise ModelError("a layout with damper valves needs its problem to solve their flows on its road; pass space")
        resistance = baseline_valve_resistance(space)
        layout = with_equivalent_valves(layout, np.where(np.isfinite(resistance), resistance, 1.0))
    return HydraulicSystem(compile_network(layout, "lumped"), system.params, system.static_rise, system.static_pressure), resistance


def operating_system(space: DesignSpace) -> HydraulicSystem:
    """The HIS of ``space``'s model of its baseline design (batch of one), as the evaluator
    builds it for the problem's own load case (:meth:`hisopt.specification.design_space.DesignSpace.model`):
    linearised at its static operating point, so the screening's stiffness is the model's
    (``K_his`` of :meth:`hisopt.coupled.model.CoupledModel.stiffness`)."""
    his = space.model().his
    if his is None:  # a model() with HIS always has one
        raise ModelError(f"{space.name}: its model has no HIS to screen")
    return his


def screened_properties(his: RollPlaneHIS, space: DesignSpace | None = None) -> dict[str, Any]:
    """:func:`pattern_properties` of :func:`layout_system` and ``damper_valves``
    (:func:`damper_valve_note`); the damping NaN where the damper valves' flows have no fixed
    point at the baseline."""
    system, resistance = screened_system(his, space)
    properties: dict[str, Any] = pattern_properties(system)
    if not np.all(np.isfinite(resistance)):
        properties |= {f"c_{p}": np.nan for p in STROKE_PATTERNS}
    return properties | {"damper_valves": damper_valve_note(his, resistance)}


def baseline_valve_resistance(space: DesignSpace) -> np.ndarray:
    """[Pa s m^-3] Each damper valve's equivalent linear resistance at ``space``'s baseline
    design on its road, in element order (NaN all through when the flows have no fixed point
    there; :func:`hisopt.evaluation.valve_states.valve_states`)."""
    from hisopt.evaluation.valve_states import valve_states

    return valve_states(space, space.baseline).resistance[0]


def with_equivalent_valves(layout: Layout, resistance: np.ndarray) -> Layout:
    """``layout`` with its damper valves, in element order, made linear valves of
    ``resistance`` [Pa s m^-3] (their equivalent resistances)."""
    values = iter(float(r) for r in resistance)
    circuits = []
    for circuit in layout.circuits:
        elements = [Valve(e.a, e.b, next(values)) if isinstance(e, DamperValve) else e for e in circuit.elements]
        circuits.append(Circuit(circuit.name, tuple(elements), circuit.ports))
    return Layout(tuple(circuits), layout.name)


def damper_valve_note(his: RollPlaneHIS, resistance: np.ndarray) -> str:
    """[-] What a layout's damper valves are and how they damp on the baseline road, one
    phrase (empty for a layout without them): ``4 damper valves (orifice 3 mm, cracking 1.5 MPa),
    equivalent resistance 2.1e9 to 3.4e9 Pa s/m^3 on the baseline road``."""
    layout = his_layout(his)
    valves = [e for c in layout.circuits for e in c.elements if isinstance(e, DamperValve)]
    if not valves:
        return ""
    values = his_parameter_values(his)

    def spread(refs: list[Any], unit: str) -> str:  # "3 mm", or "2.5 mm to 3 mm" where the valves differ
        numbers = sorted({float(values[r]) if isinstance(r, str) else float(r) for r in refs})
        ends = [format_quantity(v, unit) for v in (numbers[0], numbers[-1])]
        return ends[0] if ends[0] == ends[1] else f"{ends[0]} to {ends[1]}"

    cracking = [e.cracking_pressure for e in valves if e.cracking_pressure is not None]
    some = "" if len(cracking) in (0, len(valves)) else f" on {len(cracking)} of them"
    parts = [f"orifice {spread([e.orifice_diameter for e in valves], 'm')}", f"cracking {spread(cracking, 'Pa')}{some}" if cracking else "no blow-off"]
    head = f"{len(valves)} damper valve{'s' if len(valves) > 1 else ''} ({', '.join(parts)})"
    if not np.all(np.isfinite(resistance)):
        return f"{head}, no fixed point of their flows at the baseline (its damping is not screened)"
    ends = [format_quantity(v, RESISTANCE_UNIT) for v in (float(np.min(resistance)), float(np.max(resistance)))]
    text = ends[0] if ends[0] == ends[1] else f"{ends[0]} to {ends[1]}"
    return f"{head}, equivalent resistance {text} on the baseline road"


def pattern_properties(system: HydraulicSystem) -> dict[str, float]:
    """Static stiffness [N/m], low-frequency damping [N s/m] per unit stroke pattern and the
    largest static coupling between patterns [-] of a one-design HIS (module docstring)."""
    k = np.asarray(system.static_stiffness(), dtype=float).reshape(1, 4, 4)
    c = np.asarray(system.low_frequency_damping(), dtype=float).reshape(1, 4, 4)
    return {name: float(values[0]) for name, values in pattern_table(k, c).items()}


def pattern_table(k_his: np.ndarray, c_lf: np.ndarray) -> dict[str, np.ndarray]:
    """The screening columns of a batch: ``k_his`` [N/m] and ``c_lf`` [N s/m] of shape
    ``(B, 4, 4)`` (stroke stiffness and low-frequency damping) -> ``k_bounce`` .. ``c_warp``
    and ``stiffness_coupling``, each of shape ``(B,)`` (module docstring)."""
    u = pattern_matrix()
    k = u @ k_his @ u.T
    c = u @ c_lf @ u.T
    diag = np.abs(np.diagonal(k, axis1=-2, axis2=-1))
    scale = np.sqrt(diag[:, :, None] * diag[:, None, :])
    ratio = np.divide(np.abs(k), scale, out=np.zeros_like(k), where=scale > 0)
    ratio[ratio < 1e-12] = 0.0  # round-off of patterns that are exactly uncoupled
    upper = np.triu_indices(4, 1)
    out = {f"k_{name}": k[:, i, i] for i, name in enumerate(STROKE_PATTERNS)}
    out |= {f"c_{name}": c[:, i, i] for i, name in enumerate(STROKE_PATTERNS)}
    out["stiffness_coupling"] = np.max(ratio[:, upper[0], upper[1]], axis=-1)
    return out


def mode_stiffness(problem: DesignSpace | None = None) -> pd.DataFrame:
    """The catalogue's screening table at a problem's baseline values (module docstring).

    One row per catalogue layout, plus the problem's own layout when it is custom; columns
    ``layout``, ``k_bounce``, ``k_roll``, ``k_pitch``, ``k_warp`` [N/m], ``c_bounce``, ...
    [N s/m], ``stiffness_coupling`` [-] and ``summary``, and ``damper_valves`` when a layout
    has physical damper valves (:func:`damper_valve_note`; its damping at their equivalent
    resistance on the problem's road); units in ``attrs["units"]``.

    Parameters
    ----------
    problem : DesignSpace | None, optional
        the problem whose ``[his]`` values (the baseline design) and load case (a charged
        HIS's static pressures, the temperature, the payload: :func:`operating_system`) are
        used; None: the default problem's (docs/model.md §3.6)
    """
    from hisopt.hydraulics.roll_plane import RollPlaneHIS

    if problem is not None:
        problem_argument(problem)
    his = problem.spec.his if problem is not None else RollPlaneHIS()
    rows = []
    names = list(catalogue()) + ([CUSTOM] if his.layout == CUSTOM else [])
    for name in names:
        summary = catalogue()[name].summary if name in catalogue() else "the problem's custom layout ([[his.circuits]])"
        space = _layout_space(problem, name) if problem is not None else None
        layout_table = layout_his(his, name) if space is None else space.spec.his
        rows.append({"layout": name, **screened_properties(layout_table, space), "summary": summary})
    frame = pd.DataFrame(rows)
    if not frame["damper_valves"].astype(bool).any():
        frame = frame.drop(columns="damper_valves")
    units = {"layout": NO_UNIT, "summary": NO_UNIT, "damper_valves": NO_UNIT, "stiffness_coupling": NO_UNIT}
    units |= {c: "N/m" for c in frame.columns if c.startswith("k_")} | {c: "N s/m" for c in frame.columns if c.startswith("c_")}
    return with_units(frame, {k: v for k, v in units.items() if k in frame.columns})


def _layout_space(problem: DesignSpace, name: str) -> DesignSpace:
    """The problem with layout ``name`` (:mod:`hisopt.studies.layout_cases`; the problem
    itself for its own layout): the layout is screened on that problem's model."""
    from hisopt.studies.layout_cases import catalogue_case

    return problem if name == problem.spec.his.layout else catalogue_case(problem, name).problem  # type: ignore[arg-type]
