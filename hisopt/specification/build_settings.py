"""``[build]``: the buildability rules' settings and limits (docs/model.md §21.2).

Each key defaults to :class:`hisopt.coupled.buildability.BuildLimits`' value, whose
docstrings give the source; a value is read in the unit written (a bare number is SI).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, field_validator

from hisopt.coupled.buildability import BuildLimits
from hisopt.quantities import si

_D = BuildLimits()

CORNERING_MAX_G = 1.5
"""[g] Largest steady lateral acceleration ``[build] cornering`` takes: above any road car's
grip (racing slicks reach about 1.5 g without downforce); a larger value is a unit slip."""


class Build(BaseModel):
    """``[build]``: the settings of the buildability rules (docs/model.md §21)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    sigmas: float = Field(_D.sigmas, gt=0, le=10, description="road standard deviations a pressure, flow or force counts", json_schema_extra=si("-"))
    cornering: float = Field(_D.cornering_g, ge=0, description="steady lateral acceleration of the quasi-static pressure swing", json_schema_extra=si("g"))
    air_release_pressure: float = Field(
        _D.air_release_pressure, gt=0, description="lowest pressure in a chamber, absolute (air release)", json_schema_extra=si("Pa")
    )
    precharge_margin: float = Field(
        _D.precharge_margin, ge=1, description="an accumulator's lowest pressure over its precharge, absolute", json_schema_extra=si("-")
    )
    cylinder_pressure: float = Field(_D.cylinder_pressure, gt=0, description="rated pressure of the cylinders, gauge", json_schema_extra=si("Pa"))
    strut_load_share: float = Field(
        _D.strut_load_share, gt=0, le=1, description="largest share of its corner's sprung load the fluid carries at rest", json_schema_extra=si("-")
    )
    area_ratio_max: float = Field(_D.area_ratio_max, gt=1, description="largest cylinder area ratio bore / annulus", json_schema_extra=si("-"))
    annulus_wall: float = Field(_D.annulus_wall, gt=0, description="thinnest annulus wall (bore - rod) / 2", json_schema_extra=si("m"))
    rod_length: float = Field(_D.rod_length, gt=0, description="free length of the piston rod between its pins (Euler buckling)", json_schema_extra=si("m"))
    rod_modulus: float = Field(_D.rod_modulus, gt=0, description="Young's modulus of the rod", json_schema_extra=si("Pa"))
    buckling_safety: float = Field(_D.buckling_safety, ge=1, description="safety factor on Euler's buckling load", json_schema_extra=si("-"))
    hose_velocity: float = Field(_D.hose_velocity, gt=0, description="largest peak flow velocity in a hose", json_schema_extra=si("m/s"))
    reynolds_laminar: float = Field(_D.reynolds_laminar, gt=0, description="largest Reynolds number of the pipes' laminar law", json_schema_extra=si("-"))
    wheel_hop: float = Field(_D.wheel_hop_hz, gt=0, description="highest wheel-hop frequency (hydraulic lock above)", json_schema_extra=si("Hz"))
    wheel_damping: float = Field(_D.wheel_damping, gt=0, lt=1, description="lowest damping ratio of a wheel-hop mode", json_schema_extra=si("-"))

    @field_validator("cornering")
    @classmethod
    def _road_car_grip(cls, v: float) -> float:
        if v > CORNERING_MAX_G:
            raise ValueError(f"{v:g} g is beyond any road car's grip; expected at most {CORNERING_MAX_G:g} g (a larger value is a unit slip)")
        return v

    def limits(self, gravity_moment: bool = True) -> BuildLimits:
        """The settings as the rules take them (SI), with the problem's ``[handling] gravity_moment``."""
        return BuildLimits(
            gravity_moment=gravity_moment,
            sigmas=self.sigmas,
            cornering_g=self.cornering,
            air_release_pressure=self.air_release_pressure,
            precharge_margin=self.precharge_margin,
            cylinder_pressure=self.cylinder_pressure,
            strut_load_share=self.strut_load_share,
            area_ratio_max=self.area_ratio_max,
            annulus_wall=self.annulus_wall,
            rod_length=self.rod_length,
            rod_modulus=self.rod_modulus,
            buckling_safety=self.buckling_safety,
            hose_velocity=self.hose_velocity,
            reynolds_laminar=self.reynolds_laminar,
            wheel_hop_hz=self.wheel_hop,
            wheel_damping=self.wheel_damping,
        )
