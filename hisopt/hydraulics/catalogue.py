"""The layout catalogue and the layout of a problem's ``[his]`` table (docs/model.md §12).

``[his] layout = "NAME"`` selects a catalogue entry (default ``"roll_plane"``, the paper's);
``layout = "custom"`` takes the circuits written in ``[[his.circuits]]``. Each catalogue entry
is a data file ``hisopt/data/layouts/NAME.toml`` in the same syntax as a custom layout
(:mod:`hisopt.hydraulics.layout_file`), with a description, its source and the defaults of
the extra parameters its elements read (``[parameters]``; a problem overrides them in
``[his.parameters]``). ``roll_plane`` is built by :func:`~hisopt.hydraulics.roll_plane.roll_plane_layout`,
whose layout without pipes its data file spells out, so that today's results stay bit for bit.

``[his.pipes]`` and ``chamber_volume > 0`` apply to every layout: each chamber gets a pipe
from its port to the node the layout connects it to (``pipe_length_front``/``_rear``,
``pipe_diameter``) and the oil volume ``chamber_volume`` at its port
(:func:`with_chamber_lines`); the roll-plane builder places its pipes after the valves, as
the paper does.
"""

from __future__ import annotations

import functools
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from importlib import resources
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from hisopt.arguments import of_type
from hisopt.errors import ModelError, with_article
from hisopt.hydraulics.layout import (
    ELEMENT_KINDS,
    FIELD_UNITS,
    ChamberCompliance,
    Circuit,
    Element,
    Layout,
    Pipe,
    Port,
    field_rule_problem,
    parameter_uses,
    with_damper_valves,
)
from hisopt.hydraulics.layout_file import CircuitSpec, build_layout, check_circuits, element_label, parameter_fields
from hisopt.hydraulics.network import FLUID_PARAMETERS, compile_network, element_values, solved_flow_name, total_compliance
from hisopt.hydraulics.roll_plane import DAMPER_REAR_TIED, RollPlaneHIS, parameter_values, roll_plane_layout
from hisopt.plausibility import rule_reason
from hisopt.quantities import field_unit

if TYPE_CHECKING:
    import numpy as np

CATALOGUE_NAMES = (
    "roll_plane",
    "roll_plane_accumulator_valves",
    "roll_plane_twin_accumulator",
    "pitch_plane",
    "axle_roll",
    "side_front_rear",
)
"""The catalogue, in the order ``hisopt layouts`` lists it (one data file each)."""

CUSTOM = "custom"
"""``[his] layout`` of a layout written in ``[[his.circuits]]``."""

PIPE_PARAMETERS = ("pipe_diameter", "pipe_length_front", "pipe_length_rear")
"""Parameters ``[his.pipes]`` defines (:func:`hisopt.hydraulics.roll_plane.parameter_values`)."""

CYLINDER_PARAMETERS = ("dA", "lam", "dA_rear", "lam_rear", "bore", "rod", "bore_rear", "rod_rear")
"""Parameters every layout reads through the cylinders (not through its elements)."""

REAR_TIED = ("dA", "lam", "Rv", *DAMPER_REAR_TIED)
"""``[his]`` values whose rear counterpart (``Rv_rear``) follows them unless given
(:func:`hisopt.hydraulics.roll_plane.parameter_values`)."""


class ParameterBounds(BaseModel):
    """Study bounds of an extra parameter (``[variables]`` of a catalogue data file) [SI]."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    lower: float
    upper: float
    unit: str = ""
    description: str = ""


class LayoutFile(BaseModel):
    """A catalogue data file (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: str
    summary: str
    description: str
    source: str
    parameters: dict[str, float] = Field(default_factory=dict)
    variables: dict[str, ParameterBounds] = Field(default_factory=dict)
    circuits: list[CircuitSpec] = Field(min_length=1)

    @field_validator("circuits")
    @classmethod
    def _together(cls, v: list[CircuitSpec]) -> list[CircuitSpec]:
        problem = check_circuits(v)
        if problem:
            raise ValueError(problem)
        return v


@dataclass(frozen=True)
class CatalogueEntry:
    """A catalogue layout: its data file's contents and how it is built.

    Attributes
    ----------
    name, summary, description, source : str
        [-] texts of the data file
    parameters : Mapping[str, float]
        [SI] defaults of the extra parameters the layout's elements read
    base : Layout
        the layout without pipes and chamber volumes
    variables : Mapping[str, ParameterBounds]
        [SI] bounds of the extra parameters a layout study varies (``[variables]``
        of the data file, a problem file's syntax; the others stay at their defaults)
    """

    name: str
    summary: str
    description: str
    source: str
    parameters: Mapping[str, float]
    base: Layout
    variables: Mapping[str, ParameterBounds] = field(default_factory=dict)

    def layout(self, pipes: bool = False, chamber: bool = False) -> Layout:
        """The layout with a pipe per chamber (``pipes``) and chamber volumes (``chamber``)."""
        if self.name == "roll_plane":
            return roll_plane_layout(pipes=pipes, chamber=chamber)
        return with_chamber_lines(self.base, pipes, chamber)


def _read_entry(name: str) -> CatalogueEntry:
    path = resources.files("hisopt") / "data" / "layouts" / f"{name}.toml"
    try:
        data = LayoutFile.model_validate(tomllib.loads(path.read_text(encoding="utf-8")), strict=True)
    except (ValidationError, tomllib.TOMLDecodeError) as exc:  # a broken shipped file: an installation error
        raise ModelError(f"hisopt/data/layouts/{name}.toml: {exc}") from None
    if data.name != name:
        raise ModelError(f"hisopt/data/layouts/{name}.toml: name {data.name!r}; expected {name!r}")
    stray = [k for k, b in data.variables.items() if k not in data.parameters or not b.lower <= data.parameters[k] <= b.upper]
    if stray:
        raise ModelError(f"hisopt/data/layouts/{name}.toml: variables.{stray[0]}: expected bounds around a [parameters] default")
    return CatalogueEntry(
        name, data.summary, " ".join(data.description.split()), data.source, dict(data.parameters), build_layout(data.circuits, name), dict(data.variables)
    )


@functools.cache
def catalogue() -> dict[str, CatalogueEntry]:
    """Every catalogue entry by name, in :data:`CATALOGUE_NAMES` order (read once)."""
    return {name: _read_entry(name) for name in CATALOGUE_NAMES}


def with_chamber_lines(layout: Layout, pipes: bool, chamber: bool) -> Layout:
    """``layout`` with a pipe from every chamber's port to its node and/or the oil volume
    ``chamber_volume`` at every port (module docstring)."""
    if not (pipes or chamber):
        return layout
    circuits = []
    for circuit in layout.circuits:
        elements: list[Element] = list(circuit.elements)
        ports: list[Port] = []
        taken = set(circuit.nodes)
        for port in circuit.ports:
            node = port.node
            if pipes:
                node = f"{port.node}.{port.label}"
                while node in taken:
                    node += "'"
                taken.add(node)
                length = "pipe_length_front" if port.wheel < 2 else "pipe_length_rear"
                elements.append(Pipe(node, port.node, length, "pipe_diameter"))
            if chamber:
                elements.append(ChamberCompliance(node))
            ports.append(replace(port, node=node))
        circuits.append(Circuit(circuit.name, tuple(elements), tuple(ports)))
    return Layout(tuple(circuits), layout.name)


# --- the layout of a problem's [his] table ---------------------------------------------------
def his_fields() -> tuple[str, ...]:
    """[-] The scalar numeric ``[his]`` values every layout may refer to by name."""
    return tuple(k for k, f in RollPlaneHIS.model_fields.items() if f.annotation in (float, float | None))


def layout_defaults(his: RollPlaneHIS) -> dict[str, float]:
    """[SI] The layout's extra parameters: the catalogue defaults, then ``[his.parameters]``."""
    entry = catalogue().get(his.layout)
    return {**(dict(entry.parameters) if entry is not None else {}), **his.parameters}


def parameter_unit(name: str, uses: Mapping[str, Sequence[tuple[type, str]]]) -> str | None:
    """[-] SI unit of a ``[his]`` value or of a layout's extra parameter: its field's declared
    unit, else that of the first element field the layout reads it as (``uses``:
    :func:`~hisopt.hydraulics.layout.parameter_uses`); None if neither knows it."""
    unit = field_unit(RollPlaneHIS, name)
    if unit is None and uses.get(name):
        unit = FIELD_UNITS[uses[name][0]]
    if unit is None and name in PIPE_PARAMETERS:  # [his.pipes] values: a bore and lengths
        unit = "m"
    return unit


def his_layout(his: RollPlaneHIS) -> Layout:
    """The layout a ``[his]`` table describes, with its pipes and chamber volumes.

    Assumes a validated table (:func:`layout_problem` found nothing).
    """
    pipes, chamber = his.pipes is not None, his.chamber_volume > 0
    if his.layout == CUSTOM:
        layout = with_chamber_lines(build_layout(his.circuits or [], CUSTOM), pipes, chamber)
    else:
        layout = catalogue()[his.layout].layout(pipes, chamber)
    if his.orifice_diameter is not None:
        layout = with_damper_valves(layout, his.cracking_pressure is not None, his.valve_flow_rms is not None)
    return layout


def his_parameter_values(his: RollPlaneHIS, overrides: Mapping[str, Any] | None = None, temperature: float | np.ndarray | None = None) -> dict[str, Any]:
    """Every parameter the layout and the cylinders read: ``[his]`` values, the layout's extra
    parameters (:func:`layout_defaults`), then ``overrides`` (design variables); the fluid at
    ``temperature`` [K] (None: the reference temperature; :func:`~hisopt.hydraulics.roll_plane.parameter_values`)."""
    of_type(his, RollPlaneHIS, "his", "a problem's [his] section (problem.spec.his)")
    if overrides is not None:
        of_type(overrides, Mapping, "overrides", "a dict of parameter names to values")
    return parameter_values(his, {**layout_defaults(his), **(overrides or {})}, temperature)


def known_parameters(his: RollPlaneHIS) -> tuple[str, ...]:
    """[-] Every name an element may refer to: the ``[his]`` values, the layout's extra
    parameters, the pipe set (with ``[his.pipes]``) and the fluid."""
    pipes = PIPE_PARAMETERS if his.pipes is not None else ()
    return tuple(dict.fromkeys((*his_fields(), *layout_defaults(his), *pipes, *FLUID_PARAMETERS)))


def used_parameters(layout: Layout) -> set[str]:
    """[-] The names a layout's elements and cylinders read; a rear value's name (``Rv_rear``)
    counts its front one (``Rv``) too, which it follows unless given."""
    used = set(parameter_uses(layout)) | set(CYLINDER_PARAMETERS)
    return used | {n for n in REAR_TIED if f"{n}_rear" in used}


def layout_problem(his: RollPlaneHIS) -> str | None:
    """What is wrong with the layout of a ``[his]`` table (None: nothing), as one line
    starting with the key: an unknown catalogue name, circuits without ``layout = "custom"``
    (or the converse), circuits sharing a chamber or a name, a ``[his.parameters]`` entry that clashes with a ``[his]`` value, is not
    read by the layout or breaks the rule of an element field that reads it, an element that
    refers to an unknown parameter, a circuit whose compliance is zero at these values."""
    if his.layout != CUSTOM and his.layout not in CATALOGUE_NAMES:
        return f'his.layout: unknown layout {his.layout!r}; expected one of {", ".join(CATALOGUE_NAMES)} or "custom" (see hisopt layouts)'
    if his.layout == CUSTOM and not his.circuits:
        return 'his.layout: "custom" needs the circuits in [[his.circuits]] tables (docs/model.md §12.2)'
    if his.layout != CUSTOM and his.circuits:
        return f'his.circuits: circuits are given but layout = {his.layout!r}; expected layout = "custom" to use them'
    across = check_circuits(his.circuits or [])
    if across:
        return f"his.circuits: {across}"
    reserved = set(his_fields()) | set(PIPE_PARAMETERS) | set(FLUID_PARAMETERS) | set(CYLINDER_PARAMETERS)
    for name in his.parameters:
        if name in reserved:
            return f"his.parameters.{name}: {name!r} is a [his] value; set it in [his] itself (expected a new name here)"
    layout = his_layout(his)
    uses = parameter_uses(layout)
    for name in his.parameters:
        if name not in uses:
            read = ", ".join(n for n in uses if n not in reserved)
            want = f"expected one of the names its elements read ({read})" if read else "its elements read no such name; expected no [his.parameters]"
            return f"his.parameters.{name}: not read by layout {his.layout!r}; {want}"
    known = set(known_parameters(his))
    for c, circuit in enumerate(layout.circuits):
        for element in circuit.elements:
            for key, ref in parameter_fields(element).items():
                if isinstance(ref, str) and ref not in known:
                    extra = ", ".join(his.parameters) or "none yet"
                    return (
                        f"his.circuits: {element_label(layout, c, element)}: {key} refers to the unknown parameter {ref!r}; "
                        f"expected a number, a [his] value ({', '.join(his_fields())}) or a name defined in [his.parameters] ({extra})"
                    )
    values = his_parameter_values(his)
    for name, value in his.parameters.items():
        for cls, key in uses[name]:
            broken = field_rule_problem(cls, key, value)
            if broken:
                rule = name + broken.removeprefix(key)
                return f"his.parameters.{name}: expected {rule} (it is the {key} of {with_article(ELEMENT_KINDS[cls])}{rule_reason(key)}), got {value:g}"
    return _zero_compliance(layout, values)


def _zero_compliance(layout: Layout, values: Mapping[str, Any]) -> str | None:
    """A circuit whose every compliance is zero at ``values`` (None: none)."""
    network = compile_network(layout, "lumped")
    unsolved = {solved_flow_name(k): 0.0 for k, _, _ in network.solved_valves()}  # the flows do not change a compliance
    resolved = element_values(network, {**values, **unsolved})
    for c, circuit in enumerate(layout.circuits):
        if not float(total_compliance(network, resolved, c)) > 0.0:
            return (
                f"his.circuits: circuit {circuit.name!r} has no compliance at these values (every oil volume is 0); "
                "expected an accumulator or a non-zero volume"
            )
    return None
