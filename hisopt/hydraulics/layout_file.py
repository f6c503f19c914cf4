"""HIS layouts written as data: the ``[[his.circuits]]`` syntax of problem and catalogue files.

One syntax serves custom layouts in problem files and the catalogue's data files
(``hisopt/data/layouts/*.toml``; docs/model.md §12.2)::

    [[his.circuits]]
    name = "A"
    nodes = ["A", "A.2b", "A.4b"]
    chambers = { 1t = "A", 2b = "A.2b", 3t = "A", 4b = "A.4b" }
    elements = [
        { type = "accumulator", node = "A", volume = "V0", precharge = "p0" },
        { type = "valve", from = "A.2b", to = "A", resistance = "Rv" },
        { type = "valve", from = "A.4b", to = "A", resistance = "Rv_rear" },
    ]

A circuit declares its nodes, which chamber feeds which node (``"1t"`` .. ``"4b"``: wheel 1
FL, 2 FR, 3 RL, 4 RR; ``t`` the top/annulus, ``b`` the bottom/bore chamber) and its elements
between the nodes. Every element parameter is a number [SI] or the name of a parameter
(a ``[his]`` value, a ``[his.parameters]`` entry, a design variable).

The pydantic models check what one circuit can check alone (element fields, numbers against
each field's rule, declared nodes, dangling elements, one connected circuit closed by a
compliance); :func:`check_circuits` what needs all of them (each chamber at most once,
distinct names) and :func:`hisopt.hydraulics.catalogue.layout_problem` the parameter names
against the problem's parameters.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hisopt.errors import with_article
from hisopt.hydraulics.layout import (
    CHAMBER_LABELS,
    ELEMENT_KINDS,
    PARAMETER_FIELDS,
    Accumulator,
    ChamberCompliance,
    Circuit,
    Element,
    Layout,
    ParamRef,
    Port,
    chamber_of_label,
    field_rule_problem,
)
from hisopt.plausibility import rule_reason

ElementKind = Literal["accumulator", "compliance", "valve", "orifice", "damper_valve", "pipe"]

ELEMENT_TYPES: dict[str, type] = {kind: cls for cls, kind in ELEMENT_KINDS.items()}
"""Element class of each ``type`` of the file syntax."""

_REQUIRED: dict[str, tuple[str, ...]] = {
    "accumulator": ("node",),
    "compliance": ("node", "volume"),
    "valve": ("from", "to", "resistance"),
    "orifice": ("from", "to", "kq"),
    "damper_valve": ("from", "to", "orifice_diameter"),
    "pipe": ("from", "to", "length", "diameter"),
}
"""Keys each element type needs; the others of its :data:`PARAMETER_FIELDS` have defaults
(an accumulator's ``volume = "V0"``, ``precharge = "p0"``, ``gamma = "gamma"``; an orifice's
``resistance = 0``, its ``flow_rms`` solved; a damper valve's ``discharge_coefficient =
"discharge_coefficient"``, ``resistance = 0``, no blow-off, its RMS flow solved)."""

_PARAM_KEYS = (
    "volume",
    "precharge",
    "gamma",
    "resistance",
    "kq",
    "flow_rms",
    "orifice_diameter",
    "discharge_coefficient",
    "cracking_pressure",
    "blowoff_resistance",
    "length",
    "diameter",
)


class ElementSpec(BaseModel):
    """One element of a circuit: ``type`` and its nodes and parameters (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, populate_by_name=True)

    type: ElementKind
    node: str | None = None
    from_: str | None = Field(None, alias="from")
    to: str | None = None
    volume: float | str | None = None
    precharge: float | str | None = None
    gamma: float | str | None = None
    resistance: float | str | None = None
    kq: float | str | None = None
    flow_rms: float | str | None = None
    orifice_diameter: float | str | None = None
    discharge_coefficient: float | str | None = None
    cracking_pressure: float | str | None = None
    blowoff_resistance: float | str | None = None
    length: float | str | None = None
    diameter: float | str | None = None

    @field_validator(*_PARAM_KEYS, mode="before")
    @classmethod
    def _number_or_name(cls, v: Any) -> Any:
        if v is None or (isinstance(v, str) and v.strip() and v == v.strip()):
            return v
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            if not math.isfinite(v):
                raise ValueError(f"expected a finite number, got {v!r}")
            return float(v)
        raise ValueError("expected a number [SI units] or the name of a parameter")

    @model_validator(mode="after")
    def _keys_of_type(self) -> ElementSpec:
        cls = ELEMENT_TYPES[self.type]
        allowed = (("node",) if self.type in ("accumulator", "compliance") else ("from", "to")) + PARAMETER_FIELDS[cls]
        given = [k for k in ("node", "from", "to", *_PARAM_KEYS) if self.value(k) is not None]
        extra = [k for k in given if k not in allowed]
        if extra:
            raise ValueError(f"{with_article(self.type)} takes {', '.join(allowed)}; got {extra[0]!r}")
        missing = [k for k in _REQUIRED[self.type] if self.value(k) is None]
        if missing:
            raise ValueError(f"{with_article(self.type)} needs {', '.join(missing)} (it takes {', '.join(allowed)})")
        if self.type == "damper_valve" and (self.cracking_pressure is None) != (self.blowoff_resistance is None):
            one, other = ("cracking_pressure", "blowoff_resistance") if self.blowoff_resistance is None else ("blowoff_resistance", "cracking_pressure")
            raise ValueError(
                f"a damper valve's blow-off needs {other} with {one} (the pressure it opens at and the resistance of its opening law); give both or neither"
            )
        for key in PARAMETER_FIELDS[cls]:
            value = self.value(key)
            broken = field_rule_problem(cls, key, value) if isinstance(value, float) else None
            if broken:
                raise ValueError(f"{key}: expected {broken} for {with_article(self.type)}{rule_reason(key)}, got {value!r}")
        return self

    def value(self, key: str) -> Any:
        """The value of a file key (``"from"`` is the attribute ``from_``)."""
        return getattr(self, "from_" if key == "from" else key)

    @property
    def nodes(self) -> tuple[str, ...]:
        """The nodes the element touches."""
        return (self.node,) if self.node is not None else (str(self.from_), str(self.to))

    def describe(self) -> str:
        """``valve 'A.2b' -> 'A'``, ``accumulator at 'A'``: how messages name the element."""
        if self.node is not None:
            return f"{self.type} at {self.node!r}"
        return f"{self.type} {self.from_!r} -> {self.to!r}"

    def to_element(self) -> Element:
        """The :mod:`hisopt.hydraulics.layout` element (defaults filled in)."""
        cls = ELEMENT_TYPES[self.type]
        params = {k: self.value(k) for k in PARAMETER_FIELDS[cls] if self.value(k) is not None}
        if self.node is not None:
            return cls(self.node, **params)
        return cls(self.from_, self.to, **params)


def _is_compliance(e: ElementSpec) -> bool:
    """Whether an element stores oil (a literal zero volume does not)."""
    if e.type == "compliance":
        return e.volume != 0.0
    return e.type in ("accumulator", "pipe")


class CircuitSpec(BaseModel):
    """One closed circuit: its nodes, the chambers feeding them and its elements."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: str = Field(min_length=1)
    nodes: list[str] = Field(min_length=1)
    chambers: dict[str, str] = Field(min_length=1)
    elements: list[ElementSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _connected_and_closed(self) -> CircuitSpec:
        problem = circuit_problem(self)
        if problem:
            raise ValueError(f"circuit {self.name!r}: {problem}")
        return self

    def to_circuit(self) -> Circuit:
        """The :class:`~hisopt.hydraulics.layout.Circuit` (ports in the order of ``chambers``)."""
        ports = tuple(Port(node, *chamber_of_label(label)) for label, node in self.chambers.items())
        return Circuit(self.name, tuple(e.to_element() for e in self.elements), ports)


def circuit_problem(circuit: CircuitSpec) -> str | None:
    """What is wrong with one circuit on its own (None: nothing).

    Checked in this order: node names declared once; chamber labels; chambers and elements
    on declared nodes; no element from a node to itself; every declared node used; no
    dangling element (a series element with an end that nothing else touches); one connected
    circuit; at least one compliance (accumulator, pipe or oil volume) to close it.
    """
    declared = circuit.nodes
    twice = [n for i, n in enumerate(declared) if n in declared[:i]]
    if twice:
        return f"node {twice[0]!r} is declared twice; expected distinct names in nodes"
    if any(not n.strip() or n != n.strip() for n in declared):
        return "expected non-empty node names without surrounding spaces in nodes"
    known = ", ".join(declared)
    for label, node in circuit.chambers.items():
        if label not in CHAMBER_LABELS:
            return f"unknown chamber {label!r} in chambers; expected one of {', '.join(CHAMBER_LABELS)} (wheel 1-4 FL FR RL RR, t top, b bottom)"
        if node not in declared:
            return f"chamber {label!r} feeds the unknown node {node!r}; expected one of the declared nodes {known}"
    touches: dict[str, int] = dict.fromkeys(declared, 0)  # chambers and element ends at each node
    for node in circuit.chambers.values():
        touches[node] += 1
    for e in circuit.elements:
        for node in e.nodes:
            if node not in touches:
                return f"{e.describe()}: unknown node {node!r}; expected one of the declared nodes {known}"
        if len(set(e.nodes)) < len(e.nodes):
            return f"{e.describe()}: joins node {e.nodes[0]!r} to itself; expected two different nodes"
        for node in e.nodes:
            touches[node] += 1
    unused = [n for n, count in touches.items() if count == 0]
    if unused:
        return f"node {unused[0]!r} is declared but nothing connects to it; expected every node in nodes to be used"
    for e in circuit.elements:
        ends = [n for n in e.nodes if touches[n] == 1] if e.node is None else []
        if ends:
            return f"{e.describe()} dangles: nothing else connects to node {ends[0]!r}; expected both ends of {with_article(e.type)} connected"
    groups = _connected_groups(declared, [e.nodes for e in circuit.elements if e.node is None])
    if len(groups) > 1:
        parts = " and ".join("{" + ", ".join(g) + "}" for g in groups)
        return f"falls apart into unconnected parts {parts}; expected one connected circuit (or split it into several circuits)"
    if not any(_is_compliance(e) for e in circuit.elements):
        return "has no compliance (accumulator, pipe or oil volume): a closed incompressible circuit locks its cylinders; expected at least one accumulator"
    return None


def _connected_groups(nodes: Sequence[str], links: Sequence[tuple[str, ...]]) -> list[list[str]]:
    """The nodes in groups joined by ``links`` (pairs), each group in declaration order."""
    parent = {n: n for n in nodes}

    def root(n: str) -> str:
        while parent[n] != n:
            n = parent[n]
        return n

    for a, b in links:
        parent[root(b)] = root(a)
    groups: dict[str, list[str]] = {}
    for n in nodes:
        groups.setdefault(root(n), []).append(n)
    return list(groups.values())


def check_circuits(circuits: Sequence[CircuitSpec]) -> str | None:
    """What is wrong across circuits (None: nothing): distinct circuit names, each chamber in
    at most one circuit."""
    names = [c.name for c in circuits]
    twice = [n for i, n in enumerate(names) if n in names[:i]]
    if twice:
        return f"circuit name {twice[0]!r} is used twice; expected distinct circuit names"
    owner: dict[str, str] = {}
    for c in circuits:
        for label in c.chambers:
            if label in owner:
                return f"chamber {label!r} is used by circuit {owner[label]!r} and again by circuit {c.name!r}; expected each chamber in at most one circuit"
            owner[label] = c.name
    return None


def build_layout(circuits: Sequence[CircuitSpec], name: str) -> Layout:
    """The :class:`~hisopt.hydraulics.layout.Layout` of validated circuits."""
    return Layout(tuple(c.to_circuit() for c in circuits), name)


def element_label(layout: Layout, circuit: int, element: Element) -> str:
    """``valve 'A.2b' -> 'A'``: an element as messages name it."""
    kind = ELEMENT_KINDS[type(element)]
    where = f"circuit {layout.circuits[circuit].name!r}, "
    if isinstance(element, (Accumulator, ChamberCompliance)):
        return f"{where}{kind} at {element.node!r}"
    return f"{where}{kind} {element.a!r} -> {element.b!r}"


def parameter_fields(element: Element) -> dict[str, ParamRef]:
    """The parameter fields of an element and their values (numbers or names)."""
    return {f: getattr(element, f) for f in PARAMETER_FIELDS[type(element)]}
