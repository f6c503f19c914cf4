"""HIS layouts as data: circuits of elements between named nodes, fed by cylinder chambers.

A layout is pure structure. Every element parameter is a :data:`ParamRef`: a number [SI] or
the name of a parameter (a ``[his]`` value or a design variable), resolved per design when a
model is built (:mod:`hisopt.hydraulics.network`). So one layout serves every design of a
problem and every engine (numpy, CasADi, time domain).

Wheels are 0 FL, 1 FR, 2 RL, 3 RR; each carries a double-acting cylinder with a ``top``
(annulus, rod side) and a ``bottom`` (bore) chamber; a :class:`Port` connects one chamber to
a node of a circuit (docs/model.md §3).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Literal

from hisopt.plausibility import GAMMA_RANGE
from hisopt.quantities import field_unit, si

Chamber = Literal["top", "bottom"]

ParamRef = float | str
"""A parameter value [SI] or the name of a parameter resolved per design."""

WHEEL_LABELS = ("1", "2", "3", "4")
CHAMBER_LABELS = tuple(f"{w}{c}" for w in WHEEL_LABELS for c in "tb")
"""``"1t", "1b", ..., "4b"``: wheel number (1 FL, 2 FR, 3 RL, 4 RR) and chamber (t top, b bottom)."""


def chamber_of_label(label: str) -> tuple[int, Chamber]:
    """``"2b"`` -> ``(1, "bottom")``: wheel index (0 FL ... 3 RR) and chamber of a label."""
    if label not in CHAMBER_LABELS:
        raise ValueError(f"unknown chamber {label!r}; expected one of {', '.join(CHAMBER_LABELS)}")
    return WHEEL_LABELS.index(label[0]), "top" if label[1] == "t" else "bottom"


@dataclass(frozen=True)
class Accumulator:
    """Gas-charged accumulator at ``node`` (a shunt compliance, docs/model.md §3.3)."""

    node: str
    volume: ParamRef = dc_field(default="V0", metadata=si("m^3"))
    precharge: ParamRef = dc_field(default="p0", metadata=si("Pa"))
    gamma: ParamRef = dc_field(default="gamma", metadata=si("-"))


@dataclass(frozen=True)
class ChamberCompliance:
    """Oil compressibility of the volume at ``node`` (a shunt compliance ``V / beta``)."""

    node: str
    volume: ParamRef = dc_field(default="chamber_volume", metadata=si("m^3"))


@dataclass(frozen=True)
class Valve:
    """Linear damper valve from node ``a`` to node ``b`` (``p_a - p_b = R q``); ``R = 0`` is a
    short."""

    a: str
    b: str
    resistance: ParamRef = dc_field(default="Rv", metadata=si("Pa s m^-3"))


@dataclass(frozen=True)
class Pipe:
    """Circular pipe with laminar friction from node ``a`` to node ``b`` (lumped pi-section or
    distributed line, docs/model.md §3.4)."""

    a: str
    b: str
    length: ParamRef = dc_field(metadata=si("m"))
    diameter: ParamRef = dc_field(metadata=si("m"))


@dataclass(frozen=True)
class Orifice(Valve):
    """Orifice from node ``a`` to node ``b``: ``p_a - p_b = R q + K_q q |q|`` (docs/model.md §12.2).

    A sharp-edged orifice has no small-signal resistance at zero flow, so the linear engines
    (frequency domain, modes, linear time domain) use its equivalent linear resistance at the
    RMS flow ``flow_rms`` (:func:`hisopt.hydraulics.laws.orifice_equivalent_resistance`); left
    out (None), the RMS flow the road drives through it, solved with the response like a
    :class:`DamperValve`'s. The nonlinear time domain uses the law itself.
    """

    resistance: ParamRef = dc_field(default=0.0, metadata=si("Pa s m^-3"))
    kq: ParamRef = dc_field(default=0.0, metadata=si("Pa s^2 m^-6"))
    flow_rms: ParamRef | None = dc_field(default=None, metadata=si("m^3/s"))


@dataclass(frozen=True)
class DamperValve(Valve):
    """Physical damper valve from node ``a`` to node ``b`` (docs/model.md §3.3): a bleed
    orifice (``orifice_diameter``, ``discharge_coefficient``) in parallel with an optional
    spring-loaded blow-off (``cracking_pressure``, and ``blowoff_resistance``, the slope of
    the flow it adds once open), the pair in series with a laminar part ``resistance``
    (:func:`hisopt.hydraulics.laws.damper_valve_pressure_drop`).

    The linear engines use its equivalent linear resistance under a Gaussian flow of RMS
    ``flow_rms`` (:func:`hisopt.hydraulics.laws.damper_valve_equivalent_resistance`); left
    out (None), that RMS flow is the one the road drives through the valve, solved with the
    response as a fixed point per design and load case
    (:mod:`hisopt.evaluation.valve_flows`). The nonlinear time domain uses the law itself.
    """

    resistance: ParamRef = dc_field(default=0.0, metadata=si("Pa s m^-3"))
    orifice_diameter: ParamRef = dc_field(default="orifice_diameter", metadata=si("m"))
    discharge_coefficient: ParamRef = dc_field(default="discharge_coefficient", metadata=si("-"))
    cracking_pressure: ParamRef | None = dc_field(default=None, metadata=si("Pa"))
    blowoff_resistance: ParamRef | None = dc_field(default=None, metadata=si("Pa s m^-3"))
    flow_rms: ParamRef | None = dc_field(default=None, metadata=si("m^3/s"))


Element = Accumulator | ChamberCompliance | Valve | Orifice | DamperValve | Pipe
SeriesElement = Valve | Orifice | DamperValve | Pipe
ShuntElement = Accumulator | ChamberCompliance


PARAMETER_FIELDS: dict[type, tuple[str, ...]] = {
    Accumulator: ("volume", "precharge", "gamma"),
    ChamberCompliance: ("volume",),
    Valve: ("resistance",),
    Orifice: ("resistance", "kq", "flow_rms"),
    DamperValve: ("resistance", "orifice_diameter", "discharge_coefficient", "cracking_pressure", "blowoff_resistance", "flow_rms"),
    Pipe: ("length", "diameter"),
}
"""The fields of each element type that hold a :data:`ParamRef`."""

FIELD_UNITS: dict[tuple[type, str], str] = {(cls, f): str(field_unit(cls, f)) for cls, fields in PARAMETER_FIELDS.items() for f in fields}
"""[SI unit] of every element parameter field (declared on the element classes' fields)."""

FIELD_LOWER: dict[tuple[type, str], tuple[float, bool]] = {
    (Accumulator, "volume"): (0.0, False),
    (Accumulator, "precharge"): (0.0, True),
    (Accumulator, "gamma"): (1.0, True),
    (ChamberCompliance, "volume"): (0.0, True),
    (Valve, "resistance"): (0.0, True),
    (Orifice, "resistance"): (0.0, True),
    (Orifice, "kq"): (0.0, True),
    (Orifice, "flow_rms"): (0.0, True),
    (DamperValve, "resistance"): (0.0, True),
    (DamperValve, "orifice_diameter"): (0.0, False),
    (DamperValve, "discharge_coefficient"): (0.0, False),
    (DamperValve, "cracking_pressure"): (0.0, True),
    (DamperValve, "blowoff_resistance"): (0.0, False),
    (DamperValve, "flow_rms"): (0.0, True),
    (Pipe, "length"): (0.0, False),
    (Pipe, "diameter"): (0.0, False),
}
"""Physical rule of every element parameter field: ``(lower end, closed)``, e.g. a gas volume
``> 0`` is ``(0.0, False)`` and a precharge (gauge, as ``p0``) ``>= 0`` is ``(0.0, True)``.
Upper ends are in :data:`FIELD_UPPER`."""

FIELD_UPPER: dict[tuple[type, str], tuple[float, bool]] = {
    (Accumulator, "gamma"): (GAMMA_RANGE[1], True),
    (DamperValve, "discharge_coefficient"): (1.0, True),
}
"""The fields whose rule has an upper end too: ``(upper end, closed)`` (a polytropic exponent
``<= 2``, :data:`hisopt.plausibility.GAMMA_RANGE`)."""


def field_rule_problem(cls: type, key: str, value: float) -> str | None:
    """Which rule of element field ``key`` of ``cls`` ``value`` breaks: ``"gamma <= 2"``, or None."""
    lower, closed = FIELD_LOWER[(cls, key)]
    if not (value >= lower if closed else value > lower):
        return f"{key} {'>=' if closed else '>'} {lower:g}"
    if (cls, key) in FIELD_UPPER:
        upper, closed = FIELD_UPPER[(cls, key)]
        if not (value <= upper if closed else value < upper):
            return f"{key} {'<=' if closed else '<'} {upper:g}"
    return None


ELEMENT_KINDS: dict[type, str] = {
    Accumulator: "accumulator",
    ChamberCompliance: "compliance",
    Valve: "valve",
    Orifice: "orifice",
    DamperValve: "damper_valve",
    Pipe: "pipe",
}
"""The ``type`` of each element in a layout file (docs/model.md §12.2)."""


def parameter_uses(layout: Layout) -> dict[str, list[tuple[type, str]]]:
    """Every parameter name a layout refers to, with the ``(element type, field)`` of each use."""
    uses: dict[str, list[tuple[type, str]]] = {}
    for c in layout.circuits:
        for e in c.elements:
            for f in PARAMETER_FIELDS[type(e)]:
                value = getattr(e, f)
                if isinstance(value, str):
                    uses.setdefault(value, []).append((type(e), f))
    return uses


def element_nodes(element: Element) -> tuple[str, ...]:
    """The nodes an element touches (series: ``(a, b)``; shunt: ``(node,)``)."""
    if isinstance(element, (Valve, Pipe)):  # an Orifice is a Valve
        return (element.a, element.b)
    return (element.node,)


@dataclass(frozen=True)
class Port:
    """Chamber ``chamber`` of the cylinder at ``wheel`` (0 FL, 1 FR, 2 RL, 3 RR) feeding ``node``."""

    node: str
    wheel: int
    chamber: Chamber

    @property
    def label(self) -> str:
        """``"1t"``, ``"2b"``, ...: wheel number (1-4) and chamber letter."""
        return f"{WHEEL_LABELS[self.wheel]}{'t' if self.chamber == 'top' else 'b'}"


@dataclass(frozen=True)
class Circuit:
    """One closed hydraulic circuit: its elements and the chambers (ports) that feed it."""

    name: str
    elements: tuple[Element, ...]
    ports: tuple[Port, ...]

    @property
    def nodes(self) -> tuple[str, ...]:
        """Node names in first-use order (ports first, then elements)."""
        names: dict[str, None] = {}
        for p in self.ports:
            names.setdefault(p.node)
        for e in self.elements:
            for n in element_nodes(e):
                names.setdefault(n)
        return tuple(names)


@dataclass(frozen=True)
class Layout:
    """Circuits of a HIS (any interconnection of the eight chambers)."""

    circuits: tuple[Circuit, ...]
    name: str = "custom"

    @property
    def ports(self) -> tuple[Port, ...]:
        """Every port, circuit by circuit."""
        return tuple(p for c in self.circuits for p in c.ports)

    def parameter_names(self) -> tuple[str, ...]:
        """Names the elements refer to, in first-use order."""
        names: dict[str, None] = {}
        for c in self.circuits:
            for e in c.elements:
                for field in PARAMETER_FIELDS[type(e)]:
                    value = getattr(e, field)
                    if isinstance(value, str):
                        names.setdefault(value)
        return tuple(names)


def with_damper_valves(layout: Layout, blowoff: bool, flow_given: bool) -> Layout:
    """``layout`` with every linear valve that reads ``Rv`` or ``Rv_rear`` made a physical
    damper valve reading the axle's ``orifice_diameter``, ``discharge_coefficient``,
    ``laminar_resistance`` and (``blowoff``) ``cracking_pressure``, ``blowoff_resistance``
    (``_rear`` for a valve reading ``Rv_rear``); its RMS flow is ``valve_flow_rms`` if
    ``flow_given``, else solved (docs/model.md §3.3). Any catalogue, custom or synthesised
    layout takes physical valves this way."""
    circuits = []
    for circuit in layout.circuits:
        elements: list[Element] = []
        for e in circuit.elements:
            if type(e) is Valve and e.resistance in ("Rv", "Rv_rear"):
                axle = "_rear" if e.resistance == "Rv_rear" else ""
                e = DamperValve(
                    e.a,
                    e.b,
                    resistance="laminar_resistance",
                    orifice_diameter=f"orifice_diameter{axle}",
                    cracking_pressure=f"cracking_pressure{axle}" if blowoff else None,
                    blowoff_resistance=f"blowoff_resistance{axle}" if blowoff else None,
                    flow_rms="valve_flow_rms" if flow_given else None,
                )
            elements.append(e)
        circuits.append(Circuit(circuit.name, tuple(elements), circuit.ports))
    return Layout(tuple(circuits), layout.name)
