"""Hydraulic fluid properties (defaults: docs/model.md §3.3)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from hisopt.quantities import si


class Fluid(BaseModel):
    """Incompressible-with-compliance oil used by pipes and chamber compliances."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    rho: float = Field(870.0, gt=0, description="density", json_schema_extra=si("kg/m^3"))
    mu: float = Field(0.03, gt=0, description="dynamic viscosity", json_schema_extra=si("Pa s"))
    beta: float = Field(1.5e9, gt=0, description="effective bulk modulus", json_schema_extra=si("Pa"))
