"""Roll-plane HIS builder (paper Fig. 3, Eq. 15; docs/model.md §3.6).

Circuit A joins chambers 1t, 2b, 3t, 4b and circuit B joins 1b, 2t, 3b, 4t; one accumulator
per circuit and one damper valve per cylinder on its bottom-chamber line. Optional pipes run
from each cylinder port to its circuit node; optional chamber compliances sit at the ports.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import BaseModel, ConfigDict, Field, model_serializer, model_validator

from hisopt.hydraulics import laws
from hisopt.hydraulics.charge import REFERENCE_TEMPERATURE, Charge
from hisopt.hydraulics.coupling import HydraulicSystem
from hisopt.hydraulics.fluid import Fluid, Oil, fluid_oil_problem, oil_fluid, thermal_ratios
from hisopt.hydraulics.layout import Accumulator, ChamberCompliance, Circuit, Element, Layout, Pipe, Port, Valve
from hisopt.hydraulics.layout_file import CircuitSpec
from hisopt.hydraulics.network import Network, PipeModel, compile_network
from hisopt.plausibility import GAMMA_RANGE
from hisopt.quantities import si

CIRCUIT_CHAMBERS: dict[str, tuple[tuple[int, Literal["top", "bottom"]], ...]] = {
    "A": ((0, "top"), (1, "bottom"), (2, "top"), (3, "bottom")),
    "B": ((0, "bottom"), (1, "top"), (2, "bottom"), (3, "top")),
}


class PipeLayout(BaseModel):
    """A pipe from every cylinder port to its circuit node (example pipe set, docs/model.md §3.6)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    diameter: float = Field(0.010, gt=0, description="inner diameter", json_schema_extra=si("m"))
    length_front: float = Field(1.0, gt=0, description="front port to circuit node", json_schema_extra=si("m"))
    length_rear: float = Field(2.5, gt=0, description="rear port to circuit node", json_schema_extra=si("m"))


SEPARATOR_RATINGS = {"diaphragm": 8.0, "bladder": 4.0}
"""[-] Largest ratio of working pressure to precharge (gauge, docs/model.md §16.8) by gas
separator: a bladder folds and wears beyond about 4, a diaphragm about 8 (accumulator makers'
selection guides: HST, Parker, Stauff; a size's own is in the accumulator catalogue,
:func:`hisopt.hydraulics.parts_catalogue.accumulator_rating`; a part's data sheet gives its
own, ``[his] pressure_rating``)."""


class RollPlaneHIS(BaseModel):
    """The ``[his]`` table: parameters of the HIS; the four paper variables first (paper Table 2).

    Rear-axle ``dA``, ``lam`` and ``Rv`` are tied to the front ones unless given. ``layout``
    names a catalogue layout (default the paper's roll-plane HIS) or ``"custom"``, whose
    circuits ``[[his.circuits]]`` spells out; ``[his.parameters]`` gives values to the extra
    parameters a layout's elements refer to (docs/model.md §12).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    p0: float = Field(2.0e6, ge=0, description="accumulator gauge precharge", json_schema_extra=si("Pa"))
    dA: float = Field(10e-4, gt=0, description="bore minus annulus area A_b - A_t", json_schema_extra=si("m^2"))
    lam: float = Field(0.5, gt=0, lt=1, description="area ratio A_t / A_b", json_schema_extra=si("-"))
    Rv: float = Field(8e5, ge=0, description="damper valve coefficient", json_schema_extra=si("Pa s m^-3"))
    dA_rear: float | None = Field(None, gt=0, description="rear dA (None: = dA)", json_schema_extra=si("m^2"))
    lam_rear: float | None = Field(None, gt=0, lt=1, description="rear lam (None: = lam)", json_schema_extra=si("-"))
    Rv_rear: float | None = Field(None, ge=0, description="rear Rv (None: = Rv)", json_schema_extra=si("Pa s m^-3"))
    bore: float | None = Field(None, gt=0, description="cylinder bore diameter (with rod: sets dA and lam)", json_schema_extra=si("m"))
    rod: float | None = Field(None, gt=0, description="piston-rod diameter, less than the bore (with bore: sets dA and lam)", json_schema_extra=si("m"))
    bore_rear: float | None = Field(None, gt=0, description="rear bore (None: = bore)", json_schema_extra=si("m"))
    rod_rear: float | None = Field(None, gt=0, description="rear rod (None: = rod)", json_schema_extra=si("m"))
    V0: float = Field(1.0e-3, gt=0, description="accumulator gas volume at precharge", json_schema_extra=si("m^3"))
    gamma: float = Field(1.4, ge=GAMMA_RANGE[0], le=GAMMA_RANGE[1], description="polytropic exponent of the gas (1 to 2)", json_schema_extra=si("-"))
    chamber_volume: float = Field(0.0, ge=0, description="oil volume per chamber (0: off)", json_schema_extra=si("m^3"))
    valve_laminar_fraction: float = Field(
        1.0, ge=0, le=1, description="laminar share of the valves' coefficient at the reference temperature (the rest is orifice)", json_schema_extra=si("-")
    )
    orifice_diameter: float | None = Field(
        None, gt=0, description="bleed orifice of physical damper valves in place of the linear Rv valves (None: linear valves)", json_schema_extra=si("m")
    )
    orifice_diameter_rear: float | None = Field(None, gt=0, description="rear orifice_diameter (None: = orifice_diameter)", json_schema_extra=si("m"))
    discharge_coefficient: float = Field(0.7, gt=0, le=1, description="the bleed orifices' discharge coefficient", json_schema_extra=si("-"))
    cracking_pressure: float | None = Field(
        None, ge=0, description="the damper valves' blow-off cracking pressure (None: no blow-off)", json_schema_extra=si("Pa")
    )
    cracking_pressure_rear: float | None = Field(None, ge=0, description="rear cracking_pressure (None: = cracking_pressure)", json_schema_extra=si("Pa"))
    blowoff_resistance: float | None = Field(
        None, gt=0, description="the blow-off's resistance once open: pressure per flow it adds (its opening law)", json_schema_extra=si("Pa s m^-3")
    )
    blowoff_resistance_rear: float | None = Field(
        None, gt=0, description="rear blowoff_resistance (None: = blowoff_resistance)", json_schema_extra=si("Pa s m^-3")
    )
    laminar_resistance: float = Field(0.0, ge=0, description="the damper valves' laminar part in series (0: none)", json_schema_extra=si("Pa s m^-3"))
    valve_flow_rms: float | None = Field(
        None, ge=0, description="RMS flow to linearise the damper valves at (None: solved with the road's response)", json_schema_extra=si("m^3/s")
    )
    separator: Literal["diaphragm", "bladder"] = Field("diaphragm", description="[-] the accumulators' gas separator (sets their default pressure_rating)")
    pressure_rating: float | None = Field(
        None,
        gt=1,
        description="largest ratio of working pressure to precharge (gauge) the accumulators are rated for (None: the separator's, SEPARATOR_RATINGS)",
        json_schema_extra=si("-"),
    )
    max_working_pressure: float | None = Field(
        None,
        gt=0,
        description="largest working pressure (gauge) the accumulators are rated for (None: their catalogue size's, accumulator_rating)",
        json_schema_extra=si("Pa"),
    )
    fluid: Fluid = Field(default_factory=Fluid)
    oil: Oil = Field(default_factory=Oil)
    charge: Charge | None = None
    pipes: PipeLayout | None = None
    pipe_model: PipeModel = "lumped"
    layout: str = Field("roll_plane", min_length=1, description="[-] catalogue layout (hisopt layouts) or 'custom'")
    parameters: dict[str, float] = Field(default_factory=dict, description="[SI] values of a layout's extra parameters")
    circuits: list[CircuitSpec] | None = Field(
        None, min_length=1, description="the circuits of a custom layout (checked together by hisopt.hydraulics.catalogue.layout_problem)"
    )

    @model_serializer(mode="wrap")
    def _without_what_the_sizes_set(self, handler: Any) -> dict[str, Any]:
        # bore and rod set dA and lam: a dump without them reads back (the file could not hold both)
        data = handler(self)
        for axle in ("", "_rear"):
            if data.get(f"bore{axle}") is not None and data.get(f"rod{axle}") is not None:
                data.pop(f"dA{axle}", None)
                data.pop(f"lam{axle}", None)
        return data

    @model_validator(mode="after")
    def _cylinder_sized_once(self) -> RollPlaneHIS:
        for axle in ("", "_rear"):
            sizes = [f"{part}{axle}" for part in ("bore", "rod") if getattr(self, f"{part}{axle}") is not None]
            paper = [f"{name}{axle}" for name in ("dA", "lam") if f"{name}{axle}" in self.model_fields_set and getattr(self, f"{name}{axle}") is not None]
            if sizes and paper:
                raise ValueError(f"{paper[0]}: given with {sizes[0]}, which sizes the cylinder (bore and rod set dA and lam); expected one or the other")
        for axle in ("", "_rear"):
            bore = getattr(self, f"bore{axle}") or (self.bore if axle else None)
            rod = getattr(self, f"rod{axle}") or (self.rod if axle else None)
            if bore is not None and rod is not None and not rod < bore:
                raise ValueError(f"rod{axle}: {rod:g} m is not thinner than the bore {bore:g} m; expected a piston rod smaller than its bore")
        return self

    @model_validator(mode="after")
    def _damper_valves_complete(self) -> RollPlaneHIS:
        valve_keys = [k for k in DAMPER_KEYS if getattr(self, k) is not None and k != "orifice_diameter"]
        if self.orifice_diameter is None and valve_keys:
            raise ValueError(f"{valve_keys[0]}: a damper valve value without orifice_diameter, which turns the valves into physical damper valves; give it too")
        for axle in ("", "_rear"):
            crack, slope = getattr(self, f"cracking_pressure{axle}"), getattr(self, f"blowoff_resistance{axle}")
            front = (self.cracking_pressure, self.blowoff_resistance)
            if (crack is None and front[0] is None) != (slope is None and front[1] is None):
                given, absent = (
                    ("cracking_pressure", "blowoff_resistance") if slope is None and front[1] is None else ("blowoff_resistance", "cracking_pressure")
                )
                raise ValueError(
                    f"{given}{axle}: a blow-off needs {absent}{axle} too (the pressure it opens at and the resistance of its opening law); give both or neither"
                )
        return self

    @model_validator(mode="after")
    def _one_oil(self) -> RollPlaneHIS:
        # [his.fluid]'s density and viscosity are the oil's at the reference temperature
        # (docs/model.md §16.1): given, they must agree; not given, they are taken from it.
        reference = reference_temperature(self)
        if self.oil.temperature_problem(reference):  # refused by the problem's temperature check, with its key
            return self
        problem = fluid_oil_problem(self.fluid, self.oil, reference)
        if problem:
            raise ValueError(problem)
        object.__setattr__(self, "fluid", oil_fluid(self.fluid, self.oil, reference))  # frozen: set once, while validated
        return self

    @model_validator(mode="after")
    def _distributed_needs_pipes(self) -> RollPlaneHIS:
        if self.pipe_model == "distributed" and self.pipes is None:
            raise ValueError("pipe_model = 'distributed' needs a [his.pipes] layout")
        return self


DAMPER_KEYS = (
    "orifice_diameter",
    "orifice_diameter_rear",
    "cracking_pressure",
    "cracking_pressure_rear",
    "blowoff_resistance",
    "blowoff_resistance_rear",
    "valve_flow_rms",
)
"""[his] values of the physical damper valves (docs/model.md §3.3)."""

DAMPER_REAR_TIED = ("orifice_diameter", "cracking_pressure", "blowoff_resistance")
"""Damper valve values whose rear one follows the front one unless given."""


def roll_plane_layout(pipes: bool = False, chamber: bool = False) -> Layout:
    """The roll-plane layout (paper Fig. 3): circuits A and B of :data:`CIRCUIT_CHAMBERS`.

    One accumulator per circuit on its node; a damper valve on every bottom-chamber line
    (``Rv`` front, ``Rv_rear`` rear); with ``pipes``, a pipe from each chamber's port (after its
    valve) to the circuit node (``pipe_length_front``/``_rear``, ``pipe_diameter``); with
    ``chamber``, the oil volume ``chamber_volume`` at every port.
    """
    circuits = []
    for name, chambers in CIRCUIT_CHAMBERS.items():
        elements: list[Element] = [Accumulator(name)]
        ports = []
        for wheel, chamber_kind in chambers:
            front = wheel < 2
            port_node = f"{name}.{wheel + 1}{chamber_kind[0]}"
            # The chamber's line: damper valve (bottom chambers only), then pipe, to the node.
            pipe_start = port_node
            if chamber_kind == "bottom":
                pipe_start = name if not pipes else f"{port_node}.valve"
                elements.append(Valve(port_node, pipe_start, "Rv" if front else "Rv_rear"))
            elif not pipes:
                port_node = name  # a top chamber with no pipe sits on the circuit node
            if pipes:
                length = "pipe_length_front" if front else "pipe_length_rear"
                elements.append(Pipe(pipe_start, name, length, "pipe_diameter"))
            if chamber:
                elements.append(ChamberCompliance(port_node))
            ports.append(Port(port_node, wheel, chamber_kind))
        circuits.append(Circuit(name, tuple(elements), tuple(ports)))
    return Layout(tuple(circuits), "roll_plane")


def reference_temperature(base: RollPlaneHIS) -> float:
    """[K] The temperature ``[his]`` values are given at: the charge's, else 20 C."""
    return base.charge.temperature if base.charge is not None else REFERENCE_TEMPERATURE


def thermal_parameters(base: RollPlaneHIS, temperature: float | np.ndarray | None) -> dict[str, Any]:
    """[-] What the temperature changes, as parameters of :func:`hisopt.hydraulics.network.element_values`
    and :mod:`hisopt.coupled.operating_point`: the gas's temperature ratio ``T / T_ref`` and
    the oil's density, viscosity and volume ratios (:func:`hisopt.hydraulics.fluid.thermal_ratios`);
    at the reference temperature every ratio is 1 exactly. An array of temperatures (one per
    design) gives arrays, each element as for its temperature alone."""
    reference = reference_temperature(base)
    at = reference if temperature is None else temperature
    ratios = thermal_ratios(base.oil, at, reference)
    gas = (1.0 if at == reference else at / reference) if np.ndim(at) == 0 else np.where(np.asarray(at) == reference, 1.0, np.asarray(at) / reference)
    return {
        "gas_temperature_ratio": gas,
        "viscosity_ratio": ratios.viscosity,
        "density_ratio": ratios.density,
        "oil_volume_ratio": ratios.volume,
    }


def parameter_values(base: RollPlaneHIS, overrides: Mapping[str, ArrayLike] | None = None, temperature: float | np.ndarray | None = None) -> dict[str, Any]:
    """Every parameter the roll-plane layout and the cylinders read, for a batch of designs.

    ``[his]`` values of ``base`` with ``overrides`` (design variables: arrays of one batch
    shape ``B``, or CasADi expressions); rear-axle ``dA``, ``lam``, ``Rv`` follow the front ones
    unless given; the pipe set and the fluid at ``temperature`` [K] (None: the reference
    temperature) are spelt out (``pipe_*``, ``rho``, ``mu``, ``beta``), with the
    :func:`thermal_parameters` and, for a charged HIS, its ``gas_fraction`` and
    ``charge_oil_volume``.
    """
    values: dict[str, Any] = {k: getattr(base, k) for k, f in RollPlaneHIS.model_fields.items() if f.annotation in (float, float | None)}
    values.update(overrides or {})
    for key in ("bore", "rod"):
        if values.get(f"{key}_rear") is None:
            values[f"{key}_rear"] = values[key]
    for axle in ("", "_rear"):  # hardware sizes, where given, set the paper's dA and lam
        if values.get(f"bore{axle}") is not None and values.get(f"rod{axle}") is not None:
            values[f"dA{axle}"], values[f"lam{axle}"] = laws.bore_and_rod_parameters(values[f"bore{axle}"], values[f"rod{axle}"])
    for key in ("dA", "lam", "Rv", *DAMPER_REAR_TIED):
        if values.get(f"{key}_rear") is None:
            values[f"{key}_rear"] = values[key]
    if values.get("pressure_rating") is None:
        values["pressure_rating"] = SEPARATOR_RATINGS[base.separator]
    if base.pipes is not None:  # design variables (overrides) take the place of [his.pipes] values
        values |= {
            "pipe_diameter": base.pipes.diameter,
            "pipe_length_front": base.pipes.length_front,
            "pipe_length_rear": base.pipes.length_rear,
        } | {k: v for k, v in (overrides or {}).items() if k.startswith("pipe_")}
    thermal = thermal_parameters(base, temperature)
    values |= thermal
    fluid = oil_fluid(base.fluid, base.oil, reference_temperature(base))  # as validated; here for a model_copy's [his]
    assert fluid.rho is not None and fluid.mu is not None
    values |= {"rho": fluid.rho * thermal["density_ratio"], "mu": fluid.mu * thermal["viscosity_ratio"], "beta": fluid.beta}
    if base.charge is not None:
        values["gas_fraction"] = base.charge.gas_fraction
        values["charge_oil_volume"] = base.charge.oil_volume
    return {k: (np.asarray(v, dtype=float) if isinstance(v, (list, np.ndarray)) else v) for k, v in values.items()}


def roll_plane_network(base: RollPlaneHIS) -> Network:
    """The compiled roll-plane network of ``base``'s pipe set, chamber volume and fidelity."""
    layout = roll_plane_layout(pipes=base.pipes is not None, chamber=base.chamber_volume > 0)
    return compile_network(layout, base.pipe_model)


def roll_plane_system(params: Mapping[str, ArrayLike] | None = None, base: RollPlaneHIS | None = None) -> HydraulicSystem:
    """The roll-plane HIS for one design or a batch (``params`` override ``base``'s values)."""
    base = base or RollPlaneHIS()
    return HydraulicSystem(roll_plane_network(base), parameter_values(base, params))
