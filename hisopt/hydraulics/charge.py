"""How the circuits are filled: the paper's idealisation or a charged HIS (docs/model.md §16).

The paper linearises each accumulator at its precharge: the gas fills the whole accumulator,
the unladen circuit holds no oil in it (``[his.charge]`` absent: the *ideal* model). A real
HIS is charged above its precharge: oil is pumped in at the charge temperature until the
gas of the circuit's accumulator fills ``gas_fraction`` of it (``[his.charge]``: the
*charged* model). Both take the precharge ``p0`` as set at :attr:`Charge.temperature` (the
reference temperature, default 20 C), with the gas mass fixed from then on.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from hisopt.quantities import si

REFERENCE_TEMPERATURE = 293.15
"""[K] The temperature the precharge and the fluid's values are given at unless
``[his.charge] temperature`` says otherwise (20 C)."""


class Charge(BaseModel):
    """The ``[his.charge]`` table: a circuit charged with oil above its precharge.

    Notes
    -----
    The fill is the gas fraction of the accumulator at the charge temperature, unladen: a
    number that holds for every precharge a design may have (a charge pressure would be
    below some designs' precharge). Charging is slow, so the gas stays at the charge
    temperature: the circuit's absolute pressure is then ``p0_abs / gas_fraction``. A
    circuit with several accumulators is charged until the one of highest precharge holds
    that fraction. ``gas_fraction -> 1`` is the paper's idealisation. ``oil_volume`` is oil the
    static balance counts (it expands with temperature) but the dynamic model does not: the
    compliance ``V / beta`` of a cylinder's oil is a thousandth of an accumulator's, and
    chamber elements of it make the state matrix stiff for nothing.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    gas_fraction: float = Field(gt=0, lt=1, description="gas volume over accumulator volume at charge, unladen", json_schema_extra=si("-"))
    oil_volume: float = Field(
        0.0, ge=0, description="oil per circuit in cylinders and lines that no chamber or pipe element models", json_schema_extra=si("m^3")
    )
    temperature: float = Field(
        REFERENCE_TEMPERATURE, gt=0, description="charge temperature: the precharge and the fluid's values are given at it", json_schema_extra=si("K")
    )
