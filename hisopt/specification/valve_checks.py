"""The checks of a problem's physical damper valves that need more than one value
(docs/model.md §3.3): each returns one line starting with the key, or None.

- a valve variable (:data:`VALVE_VARIABLES`) on a layout without damper valves (no ``[his]
  orifice_diameter`` turning its ``Rv`` valves into damper valves, no ``damper_valve`` element);
- a blow-off variable on damper valves without a blow-off;
- a variable ``Rv`` or ``Rv_rear`` that the damper valves replaced (``[his] orifice_diameter``);
- a cracking pressure above the accumulators' rated working pressure (:func:`rated_pressure`),
  at the baseline and at a cracking-pressure variable's upper bound.

The single-value rules (a diameter, discharge coefficient or blow-off resistance above 0, a
discharge coefficient at most 1, a cracking pressure at least 0) live on the fields
themselves (``RollPlaneHIS``, :data:`hisopt.hydraulics.layout.FIELD_LOWER`), and a blow-off
given by half (a cracking pressure without its resistance, or the converse) in
``RollPlaneHIS`` and the layout file's element.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hisopt.hydraulics.catalogue import his_parameter_values, used_parameters
from hisopt.hydraulics.layout import Accumulator, DamperValve, Layout
from hisopt.hydraulics.layout_file import element_label
from hisopt.hydraulics.roll_plane import RollPlaneHIS
from hisopt.units import format_quantity

VALVE_VARIABLES = (
    "orifice_diameter",
    "orifice_diameter_rear",
    "discharge_coefficient",
    "cracking_pressure",
    "cracking_pressure_rear",
    "blowoff_resistance",
    "blowoff_resistance_rear",
    "laminar_resistance",
    "valve_flow_rms",
)
"""[-] The ``[his]`` values only damper valves read."""

BLOWOFF_VARIABLES = ("cracking_pressure", "cracking_pressure_rear", "blowoff_resistance", "blowoff_resistance_rear")
LINEAR_VALVE_VARIABLES = ("Rv", "Rv_rear")


def damper_valve_problem(his: RollPlaneHIS, variables: Mapping[str, Any], layout: Layout) -> str | None:
    """What is wrong with the damper valves of a problem (module docstring), None: nothing.

    ``variables``: the ``[variables]`` table (each with ``lower`` and ``upper`` [SI]);
    ``layout``: :func:`hisopt.hydraulics.catalogue.his_layout` of ``his``.
    """
    valves = [(c, e) for c, circuit in enumerate(layout.circuits) for e in circuit.elements if isinstance(e, DamperValve)]
    used = used_parameters(layout)
    for name in variables:
        if name in VALVE_VARIABLES and not valves:
            return (
                f"variables.{name}: a damper valve value, and layout {his.layout!r} has no damper valves, so it would do nothing; "
                "expected [his] orifice_diameter (the layout's Rv valves become physical damper valves) "
                f"or a damper_valve element in [[his.circuits]], or no variable {name}"
            )
        if name in BLOWOFF_VARIABLES and name not in used:
            return (
                f"variables.{name}: the damper valves have no blow-off, so it would do nothing; "
                f"expected [his] cracking_pressure and blowoff_resistance (the baseline and the opening law), or no variable {name}"
            )
        if name in LINEAR_VALVE_VARIABLES and his.orifice_diameter is not None and name not in used:
            return (
                f"variables.{name}: not read: [his] orifice_diameter makes the layout's Rv valves physical damper valves; "
                "expected their variables (orifice_diameter, cracking_pressure, ...) instead, or no orifice_diameter to keep the linear Rv valves"
            )
    return _cracking_problem(his, variables, layout, valves)


def rated_pressure(layout: Layout, values: Mapping[str, Any], variables: Mapping[str, Any] | None = None) -> tuple[float, float] | None:
    """[Pa] ``(rated, precharge)``: the accumulators' largest rated working pressure (gauge)
    and the gauge precharge it comes from, None for a layout without accumulators.

    The rating is the largest working pressure an accumulator takes: its gauge precharge times
    ``pressure_rating`` (``[his] pressure_rating``, or its separator's
    :data:`~hisopt.hydraulics.roll_plane.SEPARATOR_RATINGS`; the makers state the ratio in
    gauge, docs/model.md §16.8); it is the largest pressure difference the circuit can hold
    across a valve. Of the layout's accumulators the one with
    the largest precharge counts: at ``values`` (the baseline), or, with ``variables``, at the
    upper bound of a precharge that is a design variable (the most a design in the box allows).
    """
    precharges = []
    for circuit in layout.circuits:
        for e in circuit.elements:
            if isinstance(e, Accumulator):
                ref = e.precharge
                if isinstance(ref, str) and variables is not None and ref in variables:
                    precharges.append(float(variables[ref].upper))
                else:
                    precharges.append(float(values[ref]) if isinstance(ref, str) else float(ref))
    if not precharges:
        return None
    p0 = max(precharges)
    return p0 * float(values["pressure_rating"]), p0


def _cracking_problem(his: RollPlaneHIS, variables: Mapping[str, Any], layout: Layout, valves: list[tuple[int, DamperValve]]) -> str | None:
    """A cracking pressure (baseline, or a variable's upper bound) above :func:`rated_pressure`."""
    refs = [(c, e, e.cracking_pressure) for c, e in valves if e.cracking_pressure is not None]
    if not refs:
        return None
    values = his_parameter_values(his)
    baseline, box = rated_pressure(layout, values), rated_pressure(layout, values, variables)
    if baseline is None or box is None:
        return None
    rating = float(values["pressure_rating"])
    for c, e, ref in refs:
        p_c = float(values[ref]) if isinstance(ref, str) else float(ref)
        if p_c > baseline[0]:
            key = (
                f"his.{ref}"
                if isinstance(ref, str) and ref in RollPlaneHIS.model_fields
                else f"his.parameters.{ref}"
                if isinstance(ref, str)
                else f"his.circuits: {element_label(layout, c, e)}: cracking_pressure"
            )
            return f"{key}: {_above(p_c, baseline, rating, 'the baseline precharge')}"
        if isinstance(ref, str) and ref in variables and float(variables[ref].upper) > box[0]:
            where = "the largest precharge of the box" if box[1] != baseline[1] else "the precharge"
            return f"variables.{ref}: upper bound {_above(float(variables[ref].upper), box, rating, where)}"
    return None


def _above(p_c: float, rated: tuple[float, float], rating: float, where: str) -> str:
    """The reason text of a cracking pressure ``p_c`` [Pa] above ``rated`` (:func:`rated_pressure`)."""
    pa = format_quantity
    return (
        f"{pa(p_c, 'Pa')} is above the accumulators' rated working pressure {pa(rated[0], 'Pa')} "
        f"({where} {pa(rated[1], 'Pa')} gauge times pressure_rating {rating:g}), "
        f"so the blow-off could never open within the rating; expected a cracking pressure of at most {pa(rated[0], 'Pa')}"
    )
